"""Tracking and speeds over long traffic video: frames per second (decoding included) at 1280x720 and 1920x1080, and
the process's resident memory over ten minutes of traffic, sampled every `--every` frames. Real time is the video's
25 frames a second; the memory after the first minute should stay flat.

    python experiments/benchmarks/speed_long_video.py --model demo_data/model.onnx --out outputs/bench_speed_long

The videos are rendered into `--scenes` when missing (`conf/scene/traffic_long`: ten minutes at 1280x720, about 4 min
to render; `traffic_1080p`: one minute) and their cameras calibrated from their markers. The loop is
`vehloc-localize experiment=traffic`'s without its files: each frame through the `Localizer` (background model,
tracking, the track's crops; the model fit only for a vehicle that stops), each finished track's speed measured
(`TrackSpeeds`), the vehicles kept. Writes `speed_long.csv` (the samples), `speed_long.md` and `speed_long.png`.
"""

from __future__ import annotations

import argparse
import gc
import io
import sys
import time
from pathlib import Path

import pandas as pd

from vehloc.atomic import write_bytes, write_text
from vehloc.demo.table2_cases import calibrate_case, render_case, scene_spec
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.track_speed import SpeedStatus, TrackSpeeds
from vehloc.geometry.pipeline.video import iter_frames, video_info
from vehloc.hardware import cpu_info
from vehloc.infer.classifier import VehicleClassifier
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error

sys.path.insert(0, str(Path(__file__).resolve().parent))
from memory_loop import resident_mib  # noqa: E402

VIDEOS = {"traffic_long": "1280x720, 10 min", "traffic_1080p": "1920x1080, 1 min"}
MAX_GROWTH = 0.10
"""After the first minute, the resident memory may grow by at most this fraction to the end."""


def prepare(scene: str, folder: Path) -> tuple[Path, Path]:
    """The scene's video and its calibration, rendered and calibrated when missing."""
    video, calibration = folder / "scene" / "video.avi", folder / "calibration" / "calibration.json"
    if not video.is_file():
        print(f"rendering {scene} ...", flush=True)
        render_case(scene_spec(scene), folder)
    if not calibration.is_file():
        calibrate_case(folder, grid_step_mm=5000.0)
    return video, calibration


def run(scene: str, video: Path, calibration_path: Path, classifier: VehicleClassifier, every: int) -> pd.DataFrame:
    """The loop over the whole video; a sample every `every` frames."""
    calibration = read_calibration(calibration_path)
    localizer = Localizer(classifier, calibration, LocalizeSettings.compose(["experiment=traffic"]))
    info = video_info(video)
    speeds = TrackSpeeds(classifier, calibration, localizer.speed_params, info.fps, localizer.params.motion_jitter_px,
                         1.0 / localizer.extractor.params.scale)
    vehicles, rows = [], []
    gc.collect()
    started = time.perf_counter()
    for frame_index, frame in enumerate(iter_frames(video)):
        localizer.process(frame_index, frame)
        vehicles.extend(speeds.measure(track) for track in localizer.removed)
        if (frame_index + 1) % every == 0:
            rows.append({"video": scene, "frame": frame_index + 1, "video_s": (frame_index + 1) / info.fps,
                         "elapsed_s": time.perf_counter() - started, "rss_mib": resident_mib(),
                         "tracks_held": len(localizer.tracker.tracks), "vehicles": len(vehicles),
                         "measured": sum(v.status == SpeedStatus.MEASURED for v in vehicles)})
    vehicles.extend(speeds.measure(track) for track in localizer.finish())
    samples = pd.DataFrame(rows)
    print(f"{scene}: {info.frame_count} frames in {time.perf_counter() - started:.0f} s, {len(vehicles)} vehicles",
          flush=True)
    return samples


def summary(samples: pd.DataFrame, fps: float) -> dict[str, object]:
    last = samples.iloc[-1]
    after_minute = samples[samples["video_s"] >= 60.0]
    first = float(after_minute["rss_mib"].iloc[0]) if len(after_minute) else float("nan")
    return {"video": last["video"], "frames": int(last["frame"]), "video_min": last["video_s"] / 60.0,
            "frames_per_s": last["frame"] / last["elapsed_s"], "x_real_time": last["frame"] / last["elapsed_s"] / fps,
            "rss_at_1_min_mib": first, "rss_at_end_mib": float(last["rss_mib"]),
            "growth_after_1_min_pct": 100.0 * (float(last["rss_mib"]) / first - 1.0),
            "vehicles": int(last["vehicles"]), "measured": int(last["measured"])}


def figure(samples: pd.DataFrame) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (memory, rate) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for name, group in samples.groupby("video"):
        memory.plot(group["video_s"] / 60.0, group["rss_mib"], label=f"{name} ({VIDEOS[name]})")
        window = group["frame"].diff() / group["elapsed_s"].diff()
        rate.plot(group["video_s"] / 60.0, window, label=name)
    rate.axhline(25.0, color="grey", ls=":", lw=1, label="real time (25 fps)")
    memory.set_ylabel("resident memory (MiB)")
    rate.set_ylabel("frames per second")
    rate.set_xlabel("video time (min)")
    memory.set_title("Tracking and speeds over long traffic video")
    memory.legend(fontsize=8)
    rate.legend(fontsize=8)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    return buffer.getvalue()


@exit_on_error("experiments/benchmarks/speed_long_video.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", type=Path, required=True, help="an ONNX classifier written by vehloc-export")
    parser.add_argument("--out", type=Path, default=Path("outputs/bench_speed_long"))
    parser.add_argument("--scenes", type=Path, default=Path("outputs/traffic_scenes"), help="where the videos are kept")
    parser.add_argument("--every", type=int, default=250, help="frames between samples")
    args = parser.parse_args()
    if args.every < 1 or not args.model.is_file():
        parser.error("--every must be at least 1 and --model an existing file")
    classifier = VehicleClassifier.from_onnx(args.model)
    tables, rows = [], []
    for scene in VIDEOS:
        video, calibration = prepare(scene, args.scenes / scene)
        samples = run(scene, video, calibration, classifier, args.every)
        tables.append(samples)
        rows.append(summary(samples, video_info(video).fps))
    samples, table = pd.concat(tables, ignore_index=True), pd.DataFrame(rows)
    lines = ["# Tracking and speeds over long traffic video", "",
             f"CPU: {cpu_info().describe()}; model {args.model.name}; settings `experiment=traffic`; decoding included.",
             "", markdown_table(table, "{:.2f}"), "",
             "Real time: " + "; ".join(f"{r['video']} {r['x_real_time']:.2f}x ({'met' if r['x_real_time'] >= 1 else 'not met'})"
                                       for r in rows) + ". Memory after the first minute: "
             + "; ".join(f"{r['video']} {r['growth_after_1_min_pct']:+.1f} %" for r in rows)
             + f" (bar: at most +{100 * MAX_GROWTH:.0f} %).", ""]
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "speed_long.csv", samples.to_csv(index=False, float_format="%.3f"))
    write_text(args.out / "speed_long.md", "\n".join(lines))
    write_bytes(args.out / "speed_long.png", figure(samples))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
