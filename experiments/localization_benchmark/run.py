"""The randomized localization benchmark: seeded cases of one stopped catalog car each (every model, its
palette's colours, headings all round, 5-40 m, across the lanes, four cameras, the sun all round, with and
without plates), rendered and localized with the default settings and each camera's exact calibration, scored
as Table 2 scores a case. Settings: `conf/localization_benchmark.yaml` (Hydra overrides).

    python experiments/localization_benchmark/run.py split=dev          # the development seeds
    python experiments/localization_benchmark/run.py split=heldout      # the held-out seeds: report these
    python experiments/localization_benchmark/run.py split=both classifier=demo_data/model.onnx out=runs/bench

Writes into `out`: `cases.csv` (one row per case), `groups.csv` and `report.md` (the gates per split, the rates
per model, colour, view, heading band, distance band and camera, the reasons), `errors.png` (error against
view angle and distance) and `failures.png` (the cases that fall short of a bar).
"""

from __future__ import annotations

import time
from pathlib import Path

import hydra
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from vehloc.benchmark.report import write_report
from vehloc.benchmark.runner import CaseOutcome
from vehloc.benchmark.suite import BenchmarkSettings, run_benchmark, short_reason
from vehloc.config import config_dir
from vehloc.errors import exit_on_error


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="localization_benchmark")
@exit_on_error("localization_benchmark")
def main(cfg: DictConfig) -> None:
    settings = BenchmarkSettings.from_config(OmegaConf.to_container(cfg, resolve=True))
    out_dir = Path(cfg.out)
    start = time.perf_counter()

    def progress(number: int, total: int, outcome: CaseOutcome) -> None:
        row = outcome.row
        verdict = "ok" if outcome.picture_bgr is None else short_reason(row)
        print(f"[{number}/{total}] {row['split']} seed {row['seed']} {row['model']} ({row['camera_name']}): {verdict}"
              f" ({time.perf_counter() - start:.0f} s)", flush=True)

    outcomes = list(run_benchmark(settings, progress))
    frame = pd.DataFrame([o.row for o in outcomes])
    cells = [o.picture_bgr for o in outcomes if o.picture_bgr is not None]
    title = (f"Localization benchmark: {len(frame)} cases ({', '.join(settings.seeds)}), "
             f"{'classifier ' + settings.model.name if settings.model else 'the true model given'}")
    written = write_report(frame, out_dir, title, cells)
    print((out_dir / "report.md").read_text().split("## By")[0])
    print(f"{len(frame)} cases in {time.perf_counter() - start:.0f} s; wrote " + ", ".join(str(p) for p in written))


if __name__ == "__main__":
    main()
