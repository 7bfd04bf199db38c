"""`vehloc-demo [out=demo_data] [force=true]`: the demo set, the demo classifier and its Table 1, the ONNX
export, the Table 2 scenes rendered, calibrated and localized with the exported model, Table 2, and the report.

Every setting is checked before the first step. Each step is skipped while its output exists and was made with
the same settings (`force=true` redoes it); a failed step is named, and the steps before it stay done."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from hydra import compose
from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_dir
from vehloc.config import ConfigError, build_params, check_choice, check_range, config_dir
from vehloc.demo.scenes import TABLE2_SCENES
from vehloc.demo.stamps import finished_at, forget, is_done, mark_done, seconds_taken
from vehloc.errors import VehlocError, exit_on_error, hydra_main
from vehloc.infer.metadata import file_sha256
from vehloc.synth.demo_set import VIEWS, make_demo_set
from vehloc.train.params import check_train_config

if TYPE_CHECKING:
    from vehloc.infer.classifier import VehicleClassifier

TRAIN = [sys.executable, "-m", "vehloc.train.train"]
EXPORT = [sys.executable, "-m", "vehloc.infer.export_cli"]


@dataclass(frozen=True)
class DemoDataParams:
    per_model: int
    seed: int
    views: str
    workers: int

    def __post_init__(self) -> None:
        check_range("per_model", self.per_model, 2)
        check_range("seed", self.seed, 0)
        check_choice("views", self.views, VIEWS)
        check_range("workers", self.workers, 1)


@dataclass(frozen=True)
class DemoParams:
    """The settings of `conf/demo.yaml`."""

    out: str
    force: bool
    data: DemoDataParams
    train_experiment: str
    train_overrides: list[str]
    scenes: list[str]

    def __post_init__(self) -> None:
        unknown = [s for s in self.scenes if s not in TABLE2_SCENES]
        if unknown or not self.scenes:
            raise ConfigError(f"scenes: expected some of {', '.join(TABLE2_SCENES)}; got {unknown or 'none'}")


DEMO_MADE_MARK = ".made-by-vehloc-demo"
"""The file the demo puts in a folder it makes and may remove again (never one it did not make)."""


class StepError(VehlocError):
    """A step of the demo failed; the steps before it are kept."""


def _run_command(step: str, command: list[str], log: Path) -> None:
    """Run a vehloc command, its output shown and kept in `log`; StepError with its last line."""
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("w", encoding="utf-8") as out:
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        for line in process.stdout:
            sys.stdout.write(line)
            out.write(line)
        code = process.wait()
    if code:
        tail = [line for line in log.read_text(encoding="utf-8").splitlines() if line.strip()][-1:]
        raise StepError(f"step {step} failed (exit {code}): {' '.join(tail)} (log: {log})")


class Demo:
    """The run folder and its steps."""

    def __init__(self, params: DemoParams) -> None:
        self.params = params
        self.run_dir = Path(params.out)
        self.root = self.run_dir / "compcars"
        self.train_dir = self.run_dir / "train"
        self.model = self.run_dir / "model.onnx"
        self.seconds: dict[str, float] = {}

    def step(self, name: str, settings: dict, work: Callable[[], list[Path]]) -> None:
        """Run `work` unless the step is done with these settings; record its outputs and time."""
        if self.params.force:
            forget(self.run_dir, name)
        if is_done(self.run_dir, name, settings):
            self.seconds[name] = seconds_taken(self.run_dir, name) or 0.0
            print(f"[demo] {name}: done before, skipped (force=true redoes it)", flush=True)
            return
        print(f"[demo] {name} ...", flush=True)
        start = time.perf_counter()
        outputs = work()
        self.seconds[name] = time.perf_counter() - start
        mark_done(self.run_dir, name, settings, outputs, self.seconds[name])
        print(f"[demo] {name}: {self.seconds[name]:.0f} s", flush=True)

    def data(self) -> list[Path]:
        d = self.params.data
        make_demo_set(self.root, d.per_model, d.seed, workers=d.workers, views=d.views)
        return [self.root]

    def train(self) -> list[Path]:
        mark = self.train_dir / DEMO_MADE_MARK
        if self.train_dir.exists():
            if not (mark.is_file() or finished_at(self.run_dir, "train") is not None):
                raise StepError(f"step train: {self.train_dir} exists and was not made by vehloc-demo; it is left as "
                                "it is (move it, or give another out=)")
            shutil.rmtree(self.train_dir)  # an unfinished run of other settings, made by this demo
        self.train_dir.mkdir(parents=True)
        mark.write_text("made by vehloc-demo: its train step may remove this folder to train again\n", encoding="utf-8")
        _run_command("train", [*TRAIN, f"experiment={self.params.train_experiment}", f"data.root={self.root}",
                               f"hydra.run.dir={self.train_dir}", *self.params.train_overrides],
                     self.run_dir / "logs" / "train.log")
        return [self.best_checkpoint(), self.train_dir / "table1" / "report.md"]

    def best_checkpoint(self) -> Path:
        found = sorted((self.train_dir / "checkpoints").glob("epoch_*.ckpt"))
        if not found:
            raise StepError(f"step train: no best checkpoint in {self.train_dir / 'checkpoints'}")
        return found[-1]

    def export(self) -> list[Path]:
        _run_command("export", [*EXPORT, f"ckpt_path={self.best_checkpoint()}",
                                f"data_root={self.root}", f"output={self.model}",
                                f"hydra.run.dir={self.run_dir / 'export'}"], self.run_dir / "logs" / "export.log")
        return [self.model]

    def start_scenes(self, pool: ProcessPoolExecutor) -> dict[str, Future]:
        """Render and calibrate, in `pool`, the scenes whose step is not done."""
        pending = [n for n in self.params.scenes
                   if self.params.force or not is_done(self.run_dir, f"scene_{n}", {"scene": n})]
        from vehloc.demo.table2_cases import render_and_calibrate_case

        return {n: pool.submit(render_and_calibrate_case, n, self.run_dir / "table2" / n) for n in pending}

    def localize(self, name: str, classifier: VehicleClassifier) -> list[Path]:
        from vehloc.demo.table2_cases import localize_case

        folder = self.run_dir / "table2" / name
        localize_case(folder, classifier)
        return [folder / "localize" / "table2.csv"]

    def run(self) -> Path:
        import pandas as pd  # the work's modules after the settings' checks: a refusal answers sooner
        from tqdm import tqdm

        from vehloc.demo.report import write_report
        from vehloc.demo.table2_cases import case_table
        from vehloc.geometry.pipeline.evaluation import write_table2
        from vehloc.hardware import cpu_info
        from vehloc.infer.classifier import VehicleClassifier

        d = self.params.data
        self.step("data", {"per_model": d.per_model, "seed": d.seed, "views": d.views}, self.data)
        self.step("train", {"experiment": self.params.train_experiment, "overrides": self.params.train_overrides,
                            "data": finished_at(self.run_dir, "data")}, self.train)
        self.step("export", {"checkpoint": file_sha256(self.best_checkpoint())}, self.export)
        pool = ProcessPoolExecutor(self.params.data.workers)
        try:
            rendering = self.start_scenes(pool)  # while the scenes before them are localized
            classifier = VehicleClassifier.from_onnx(self.model)
            model_sha = file_sha256(self.model)
            for name in tqdm(self.params.scenes, desc="Table 2 scenes", unit="scene", disable=None):
                try:
                    self.step(f"scene_{name}", {"scene": name}, lambda: rendering[name].result())
                    self.step(f"localize_{name}", {"scene": name, "model": model_sha},
                              lambda: self.localize(name, classifier))
                except VehlocError as err:
                    raise StepError(f"step table2 ({name}) failed: {err}") from None
        finally:
            pool.shutdown(cancel_futures=True)
        table = pd.concat([case_table(self.run_dir / "table2" / n) for n in self.params.scenes], ignore_index=True)
        table2_md = self.run_dir / "table2" / "table2.md"
        write_table2(table, table2_md.parent, f"Table 2: {len(self.params.scenes)} scenes, model {self.model.name}")
        header = (f"Made by `vehloc-demo out={self.run_dir}` on {cpu_info().describe()}; demo set of {d.per_model} "
                  f"images a model ({d.views} views), classifier exported to `{self.model.name}`.")
        return write_report(self.run_dir, self.train_dir / "table1", table, table2_md, self.step_times(), header)[0]

    def step_times(self) -> dict[str, float]:
        """Seconds per step, the per-scene steps summed into rendering (with calibration; the seconds waited for
        it, as the scenes render in the background) and localization."""
        per_scene = ("scene_", "localize_")
        once = {name: seconds for name, seconds in self.seconds.items() if not name.startswith(per_scene)}
        return once | {"scenes (render + calibrate)": sum(v for k, v in self.seconds.items() if k.startswith("scene_")),
                       "localize": sum(v for k, v in self.seconds.items() if k.startswith("localize_"))}


def check_demo_config(cfg: DictConfig) -> DemoParams:
    """The demo's settings, and the training overrides composed, before any work."""
    values = OmegaConf.to_container(cfg, resolve=True)
    params = build_params(DemoParams, {k: v for k, v in values.items() if k != "hydra"}, "")
    root = Path(params.out) / "compcars"
    if not (config_dir() / "experiment" / f"{params.train_experiment}.yaml").is_file():
        raise ConfigError(f"train_experiment: no conf/experiment/{params.train_experiment}.yaml in {config_dir()}")
    try:
        train_cfg = compose("train", overrides=[f"experiment={params.train_experiment}", f"data.root={root}",
                                                *params.train_overrides])
    except Exception as exc:  # Hydra's own errors for a bad override
        raise ConfigError(f"train_overrides: {str(exc).splitlines()[0]}") from None
    try:
        check_train_config(train_cfg)
    except ConfigError as err:
        raise ConfigError(f"train_overrides: {err}") from None
    check_output_dir(Path(params.out), "out")
    return params


@exit_on_error("vehloc-demo")
def _run(cfg: DictConfig) -> None:
    start = time.perf_counter()
    report = Demo(check_demo_config(cfg)).run()
    print(f"[demo] done in {time.perf_counter() - start:.0f} s: {report}")


@hydra_main("vehloc-demo", str(config_dir()), "demo")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
