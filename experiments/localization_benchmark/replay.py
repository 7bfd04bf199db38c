"""The paper's key points made again on a benchmark run's captured inputs, with other detector settings: no scene is
rendered, tracked or fitted, so 200 cases take seconds, not minutes (`vehloc.benchmark.replay`); with `refit=true`
the whole stop record is made again (the model fit and its starts too), in the fits' time alone.

    python experiments/localization_benchmark/run.py split=dev capture=runs/dev_capture out=runs/dev_base
    python experiments/localization_benchmark/replay.py capture=runs/dev_capture out=runs/replay_base
    python experiments/localization_benchmark/replay.py capture=runs/dev_capture out=runs/replay_overlap \
        localize.wheels.min_ellipse_overlap=0.7
    python experiments/localization_benchmark/compare.py runs/replay_base runs/replay_overlap --out runs/compare
    python experiments/localization_benchmark/replay.py capture=runs/dev_capture refit=true out=runs/refit_grid \
        localize.fit.min_grid_px=256

Settings: `conf/localization_benchmark.yaml` (`capture`, `refit`, `workers`, `out` and every `localize.` stage
setting; the detectors' and the pipeline's turning of a placement into the paper's box are the ones replayed, and with
`refit` the fit's and the pipeline's after the classification too). Writes into `out` what a run writes (`cases.csv`,
`groups.csv`, `report.md`, `errors.png`), the paper's columns made again (with `refit`, the record's) and every other
column the captured run's.
"""

from __future__ import annotations

import time
from pathlib import Path

import hydra
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_dir
from vehloc.benchmark.replay import read_captures, replay
from vehloc.benchmark.report import write_report
from vehloc.benchmark.suite import count_setting
from vehloc.config import ConfigError, config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.pipeline.settings import LocalizeSettings


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="localization_benchmark")
@exit_on_error("experiments/localization_benchmark/replay.py")
def main(cfg: DictConfig) -> None:
    values = OmegaConf.to_container(cfg, resolve=True)
    if values.get("capture") is None:
        raise ConfigError("capture: the folder of a benchmark run made with capture=DIR is needed")
    settings = LocalizeSettings.from_mapping(values["localize"])
    refit = values.get("refit")
    if not isinstance(refit, bool):
        raise ConfigError(f"refit: must be true or false, got {refit!r}")
    workers = count_setting(values, "workers")
    out_dir = check_output_dir(values["out"])
    start = time.perf_counter()
    captures = read_captures(values["capture"])
    frame = pd.DataFrame(replay(captures, settings, refit, workers if refit else 1))
    what = "stop records" if refit else "paper's key points"
    title = f"Localization benchmark replayed: the {what} of {len(frame)} cases of {values['capture']}"
    written = write_report(frame, Path(out_dir), title, [])
    print((Path(out_dir) / "report.md").read_text().split("## By")[0])
    print(f"{len(frame)} cases in {time.perf_counter() - start:.1f} s; wrote " + ", ".join(str(p) for p in written))


if __name__ == "__main__":
    main()
