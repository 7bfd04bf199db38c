"""An exported classifier in fp32 and INT8 (`vehloc-export quantize=int8`) side by side in one run, on this CPU:
the network's milliseconds per image at batch 1 and batch 32 (onnxruntime, rounds alternating between the two
models so that the machine's drift falls on both), and, with a video and its calibration, `vehloc-localize`'s
work per frame (tracks, classification, speeds) with each model and how far their results differ.

    vehloc-export onnx_path=demo_data/model.onnx quantize=int8 data_root=demo_data/compcars
    vehloc-scene scene=traffic_720p out=runs/traffic
    vehloc-calibrate site=runs/traffic/site.yaml image=runs/traffic/video.avi hydra.run.dir=runs/traffic/calibration
    python experiments/benchmarks/int8_vs_fp32.py --fp32 demo_data/model.onnx --int8 demo_data/model.int8.onnx \
        --video runs/traffic/video.avi --calibration runs/traffic/calibration/calibration.json --out runs/bench_int8

Writes `int8_vs_fp32.csv`, `int8_vs_fp32.md` and `int8_vs_fp32.png` into `--out`; the CPU and whether it has
int8 dot products (VNNI) head the table.
"""

from __future__ import annotations

import argparse
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pandas as pd
from matplotlib.figure import Figure

from vehloc.atomic import atomic_path, write_text
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.speed import SpeedFit
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.hardware import cpu_info
from vehloc.infer.classifier import VehicleClassifier
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error

PRECISIONS = ("fp32", "int8")


class TimedClassifier(VehicleClassifier):
    """The classifier, counting the milliseconds spent classifying (preprocessing included)."""

    def __init__(self, classifier: VehicleClassifier) -> None:
        super().__init__(classifier.session, classifier.metadata, classifier.source)
        self.total_ms = 0.0

    def probabilities(self, *args: object, **kwargs: object) -> np.ndarray:
        start = time.perf_counter()
        result = super().probabilities(*args, **kwargs)
        self.total_ms += 1000.0 * (time.perf_counter() - start)
        return result


def network_ms_per_image(classifiers: dict[str, VehicleClassifier], batch: int, rounds: int,
                         round_s: float) -> dict[str, list[float]]:
    """Each model's milliseconds per image in each round (the network alone, on a fixed random batch)."""
    size = next(iter(classifiers.values())).metadata.preprocessing.input_size_px
    inputs = np.random.default_rng(0).random((batch, 3, size, size), dtype=np.float32)
    times: dict[str, list[float]] = {name: [] for name in classifiers}
    for name, classifier in classifiers.items():  # warm-up
        for _ in range(3):
            classifier.session.run(None, {classifier.metadata.input_name: inputs})
    for round_index in range(rounds):
        order = list(classifiers) if round_index % 2 == 0 else list(reversed(classifiers))
        for name in order:
            session, input_name = classifiers[name].session, classifiers[name].metadata.input_name
            runs, start = 0, time.perf_counter()
            while time.perf_counter() - start < round_s:
                session.run(None, {input_name: inputs})
                runs += 1
            times[name].append(1000.0 * (time.perf_counter() - start) / (runs * batch))
    return times


def localize_once(classifier: VehicleClassifier, video: Path, calibration: Path,
                  max_frames: int | None) -> tuple[float, float, int, pd.DataFrame]:
    """`vehloc-localize`'s work over the video with this classifier (no pictures): milliseconds per frame, of
    them classification, the frame count, and the vehicles (track id, model, speed)."""
    timed = TimedClassifier(classifier)
    localizer = Localizer(timed, read_calibration(calibration), LocalizeSettings.compose())
    with tempfile.TemporaryDirectory(prefix="vehloc-bench-") as scratch:
        start = time.perf_counter()
        result = localize_video(localizer, video, Path(scratch), max_frames=max_frames, pictures=False,
                                progress=False)
        seconds = time.perf_counter() - start
    vehicles = pd.DataFrame([{"track_id": v.track_id, "model_id": v.model_id,
                              "speed_kmh": v.speed.speed_kmh if isinstance(v.speed, SpeedFit) else np.nan} for v in result.vehicles])
    return 1000.0 * seconds / result.frames, timed.total_ms / result.frames, result.frames, vehicles


def pipeline_rows(classifiers: dict[str, VehicleClassifier], video: Path, calibration: Path, rounds: int,
                  max_frames: int | None) -> tuple[list[dict[str, object]], str]:
    """Per model: the pipeline's median ms per frame over `rounds` alternating runs; and a line on how far the two
    models' vehicles differ (voted model, speed)."""
    per_frame: dict[str, list[tuple[float, float]]] = {name: [] for name in classifiers}
    vehicles, frames = {}, 0
    for round_index in range(rounds):
        order = list(classifiers) if round_index % 2 == 0 else list(reversed(classifiers))
        for name in order:
            print(f"localizing {video} with the {name} model (round {round_index + 1} of {rounds})", flush=True)
            total_ms, classify_ms, frames, vehicles[name] = localize_once(classifiers[name], video, calibration,
                                                                          max_frames)
            per_frame[name].append((total_ms, classify_ms))
    rows = []
    for name, values in per_frame.items():
        total, classify = np.median(np.array(values), axis=0)
        rows.append({"measure": f"vehloc-localize, ms per frame ({frames} frames)", "precision": name,
                     "batch": "", "ms": total, "classification_ms": classify})
    both = vehicles["fp32"].merge(vehicles["int8"], on="track_id", suffixes=("_fp32", "_int8"))
    same_model = int((both["model_id_fp32"] == both["model_id_int8"]).sum())
    speed_diff = (both["speed_kmh_fp32"] - both["speed_kmh_int8"]).abs()
    line = (f"The two models' vehicles: the same voted model for {same_model} of {len(both)}; speeds measured by both "
            f"differ by {speed_diff.median():.3f} km/h median, {speed_diff.max():.3f} km/h at most "
            f"({int(speed_diff.notna().sum())} vehicles with a speed from both).")
    return rows, line


def write_png(table: pd.DataFrame, path: Path, title: str) -> None:
    """Bars of ms per image (network, per batch) and ms per frame (pipeline), fp32 beside INT8."""
    groups = list(dict.fromkeys(table["measure"] + table["batch"].map(lambda b: f" (batch {b})" if b != "" else "")))
    fig = Figure(figsize=(9, 4.5))
    ax = fig.subplots()
    width = 0.38
    for offset, precision in zip((-width / 2, width / 2), PRECISIONS):
        rows = table[table["precision"] == precision]
        values = rows["ms"].to_numpy()
        bars = ax.bar(np.arange(len(values)) + offset, values, width, label=precision.upper())
        ax.bar_label(bars, fmt="%.2f", fontsize=8)
    ax.set_xticks(range(len(groups)), [g.replace(", ", ",\n") for g in groups], fontsize=8)
    ax.set_ylabel("milliseconds")
    ax.set_title(textwrap.fill(title, 120), fontsize=8)
    ax.legend()
    fig.tight_layout()
    with atomic_path(path, ".png") as temporary:
        fig.savefig(temporary, dpi=120)


@exit_on_error("experiments/benchmarks/int8_vs_fp32.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fp32", type=Path, required=True, help="the fp32 model of vehloc-export")
    parser.add_argument("--int8", type=Path, required=True, help="its INT8 model (vehloc-export quantize=int8)")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--video", type=Path, help="a video for the pipeline's timing (with --calibration)")
    parser.add_argument("--calibration", type=Path)
    parser.add_argument("--max-frames", type=int, default=600)
    parser.add_argument("--rounds", type=int, default=6, help="alternating timing rounds per batch size")
    parser.add_argument("--round-seconds", type=float, default=1.0)
    parser.add_argument("--pipeline-rounds", type=int, default=2)
    parser.add_argument("--threads", type=int, default=0,
                        help="onnxruntime's intra-op threads for both models (0: its default, one per core)")
    args = parser.parse_args()
    if (args.video is None) != (args.calibration is None):
        parser.error("--video and --calibration go together")

    options = ort.SessionOptions()
    options.intra_op_num_threads = args.threads
    classifiers = {}
    for name, path in zip(PRECISIONS, (args.fp32, args.int8)):
        loaded = VehicleClassifier.from_onnx(path, ["CPUExecutionProvider"])  # checks the file and its metadata
        session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        classifiers[name] = VehicleClassifier(session, loaded.metadata, loaded.source)
    for name, classifier in classifiers.items():
        if classifier.metadata.precision != name:
            parser.error(f"--{name} {classifier.source}: is an {classifier.metadata.precision} model")
    cpu = cpu_info()
    threads = args.threads or cpu.logical_cores
    rows = []
    for batch in (1, 32):
        print(f"timing the networks at batch {batch}", flush=True)
        times = network_ms_per_image(classifiers, batch, args.rounds, args.round_seconds)
        for name in PRECISIONS:
            rows.append({"measure": "network, ms per image", "precision": name, "batch": batch,
                         "ms": float(np.median(times[name])), "classification_ms": np.nan})
    lines = []
    if args.video is not None:
        pipeline, line = pipeline_rows(classifiers, args.video, args.calibration, args.pipeline_rounds, args.max_frames)
        rows += pipeline
        lines.append(line)
    table = pd.DataFrame(rows)
    ratios = []
    for (measure, batch), group in table.groupby(["measure", "batch"], sort=False):
        ms = group.set_index("precision")["ms"]
        ratios.append(f"{measure}{f' at batch {batch}' if batch != '' else ''}: INT8 {ms['fp32'] / ms['int8']:.2f}x "
                      f"faster")
    title = (f"fp32 vs INT8 on {cpu.describe()}; onnxruntime {ort.__version__}, {threads} threads; "
             f"{args.fp32.name} vs {args.int8.name}")
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "int8_vs_fp32.csv", table.to_csv(index=False, float_format="%.3f"))
    shown = table.astype(object).where(table.notna(), "")
    ratio_list = "\n".join(f"- {r}" for r in ratios)
    write_text(args.out / "int8_vs_fp32.md", "\n\n".join([f"# {title}", markdown_table(shown), ratio_list, *lines]) + "\n")
    write_png(table, args.out / "int8_vs_fp32.png", title)
    print(title)
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    print("\n".join(ratios + lines))


if __name__ == "__main__":
    main()
