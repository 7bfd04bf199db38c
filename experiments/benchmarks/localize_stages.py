"""Milliseconds per frame for each stage of the localization pipeline, and the whole pipeline as a multiple of
the classifier's own batch-1 time, measured in one run on one video.

    vehloc-scene scene=table2_plate_middle_0 out=runs/scene
    vehloc-calibrate site=runs/scene/site.yaml image=runs/scene/video.avi hydra.run.dir=runs/scene/calibration
    python experiments/benchmarks/localize_stages.py --video runs/scene/video.avi \
        --calibration runs/scene/calibration/calibration.json --model demo_data/model.onnx --out runs/bench

Both modes run: records when a vehicle stops (the default) and every frame (`every_frame=true`, a full
localization of each vehicle in view at every frame). Writes `stages.csv` and `stages.md` into `--out`.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.atomic import write_text
from vehloc.data.boxes import Box
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.timing import StageClock
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.hardware import cpu_info
from vehloc.infer.classifier import VehicleClassifier
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error

STAGES = ("decode", "background", "tracking", "classification", "key points", "model fit")


def classifier_batch1_ms(classifier: VehicleClassifier, frame_bgr: np.ndarray, box: Box, repeats: int) -> float:
    """Median wall time of classifying one crop (preprocessing included), after a warm-up."""
    for _ in range(3):
        classifier.probabilities([frame_bgr], [box])
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        classifier.probabilities([frame_bgr], [box])
        times.append(time.perf_counter() - start)
    return 1000.0 * float(np.median(times))


def run_mode(video: Path, classifier: VehicleClassifier, calibration_path: Path, every_frame: bool,
             max_frames: int | None) -> tuple[StageClock, int, list[float], Box | None, np.ndarray | None]:
    """Run the pipeline over the video; the clock, the frame count, the pipeline's seconds at each frame with
    one vehicle in view, and a box and frame of a vehicle (for the classifier's own timing)."""
    clock = StageClock()
    localizer = Localizer(classifier, read_calibration(calibration_path),
                          LocalizeSettings.compose([f"pipeline.every_frame={str(every_frame).lower()}"]),
                          clock=clock)
    frames = iter_frames(video)
    frame_count, one_in_view_s, sample = 0, [], (None, None)
    while max_frames is None or frame_count < max_frames:
        with clock.stage("decode"):
            frame = next(frames, None)
        if frame is None:
            break
        start = time.perf_counter()
        localizer.process(frame_count, frame)
        seconds = time.perf_counter() - start
        live = [t for t in localizer.tracker.tracks if t.last_frame == frame_count]
        if len(live) == 1:
            one_in_view_s.append(seconds)
            sample = (live[0].box, frame)
        frame_count += 1
    return clock, frame_count, one_in_view_s, *sample


def stage_rows(clock: StageClock, frame_count: int, one_in_view_s: list[float], batch1_ms: float,
               mode: str) -> list[dict[str, object]]:
    rows = []
    for stage in STAGES:
        rows.append({"mode": mode, "stage": stage, "calls": clock.calls(stage), "total_ms": clock.total_ms(stage),
                     "ms_per_frame": clock.total_ms(stage) / frame_count})
    pipeline_ms = sum(clock.total_ms(s) for s in STAGES if s != "decode") / frame_count
    rows.append({"mode": mode, "stage": "pipeline (without decode)", "calls": frame_count,
                 "total_ms": pipeline_ms * frame_count, "ms_per_frame": pipeline_ms,
                 "x_classifier_batch1": pipeline_ms / batch1_ms})
    for statistic, value in (("mean", np.mean), ("median", np.median)):
        in_view_ms = 1000.0 * float(value(one_in_view_s))
        rows.append({"mode": mode, "stage": f"pipeline, frames with one vehicle in view ({statistic})",
                     "calls": len(one_in_view_s), "total_ms": 1000.0 * float(np.sum(one_in_view_s)),
                     "ms_per_frame": in_view_ms, "x_classifier_batch1": in_view_ms / batch1_ms})
    whole_ms = pipeline_ms + clock.total_ms("decode") / frame_count
    rows.append({"mode": mode, "stage": "whole (with decode)", "calls": frame_count, "total_ms": whole_ms * frame_count,
                 "ms_per_frame": whole_ms, "x_classifier_batch1": whole_ms / batch1_ms})
    return rows


@exit_on_error("experiments/benchmarks/localize_stages.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--video", type=Path, required=True)
    parser.add_argument("--calibration", type=Path, required=True)
    parser.add_argument("--model", type=Path, required=True, help="an exported vehloc .onnx classifier")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--max-frames", type=int, default=None)
    parser.add_argument("--repeats", type=int, default=50, help="timed batch-1 classifications")
    args = parser.parse_args()

    classifier = VehicleClassifier.from_onnx(args.model)
    rows, batch1_ms = [], None
    for mode, every_frame in (("when stopped", False), ("every frame", True)):
        print(f"running the pipeline ({mode}) over {args.video}", flush=True)
        clock, frames, one_in_view_s, box, frame = run_mode(args.video, classifier, args.calibration, every_frame,
                                                          args.max_frames)
        if box is None:
            raise SystemExit(f"{args.video}: no frame with one vehicle in view")
        if batch1_ms is None:
            batch1_ms = classifier_batch1_ms(classifier, frame, box, args.repeats)
        rows += stage_rows(clock, frames, one_in_view_s, batch1_ms, mode)
        print(f"{frames} frames, {len(one_in_view_s)} with one vehicle in view", flush=True)

    table = pd.DataFrame(rows)
    cpu = cpu_info()
    title = (f"Localization stages on {args.video.name} ({cpu.model_name}, {cpu.logical_cores} logical cores, "
             f"Python {platform.python_version()}); classifier batch-1: {batch1_ms:.1f} ms")
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "stages.csv", table.to_csv(index=False, float_format="%.2f"))
    shown = table.astype(object).where(table.notna(), "")
    write_text(args.out / "stages.md", f"# {title}\n\n{markdown_table(shown)}\n")
    print(title)
    print(table.to_string(index=False, float_format=lambda v: f"{v:.2f}"))


if __name__ == "__main__":
    main()
