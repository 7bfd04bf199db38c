"""A video's vehicles as files: `tracks.csv` (one row per vehicle), `trajectories.csv` (one row per vehicle per
frame), `system_vehloc.json` (the speed benchmark's results format), `speeds.png` (their distribution) and
`speeds_frame<N>.png` (a few frames with each measured vehicle's box, id and speed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehloc.atomic import write_bytes, write_image, write_text
from vehloc.geometry.brno import BrnoCalibration, brno_calibration
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.pipeline.brno_files import RESULTS_NAME, results_json
from vehloc.geometry.pipeline.track_speed import ModelSource, SpeedStatus, VehicleSpeed
from vehloc.geometry.pipeline.video import iter_frames

OVERLAY_FRAMES = 4
"""How many frames are drawn with the vehicles' ids and speeds: those with the most measured vehicles in view."""
MAX_SCALE_POINTS = 400
"""The road points the benchmark's scale is fitted on: at most this many of the vehicles' path points."""


def benchmark_calibration(calibration: CameraCalibration, vehicles: list[VehicleSpeed]) -> BrnoCalibration | str:
    """The benchmark's calibration block for this camera (the pinhole camera recovered from its homography), its scale
    fitted where the vehicles were measured (over the image's lower half where none was); the reason as a sentence
    where the camera cannot be written that way."""
    if calibration.camera is None:
        return "no pinhole camera can be recovered from the calibration"
    points = np.concatenate([v.path.points_mm for v in vehicles if len(v.path.frames)] or [np.zeros((0, 2))])
    if len(points) < 2:
        width_px, height_px = calibration.image_size_px
        grid = np.array([[x, y] for x in np.linspace(0.1, 0.9, 5) * width_px for y in np.linspace(0.55, 0.95, 5) * height_px])
        points = calibration.road_to_image.inverse(grid)
    points = points[np.linspace(0, len(points) - 1, min(len(points), MAX_SCALE_POINTS)).astype(int)]
    try:
        return brno_calibration(calibration.camera, calibration.camera.road_to_image(), points)
    except ValueError as err:
        return str(err)


def speed_plot(vehicles: list[VehicleSpeed], title: str) -> bytes:
    """A histogram of the measured speeds, stacked by lane (numbered from the road's left), with the vehicles not
    measured counted in the title."""
    import io

    from matplotlib.figure import Figure

    measured = [v for v in vehicles if v.status == SpeedStatus.MEASURED]
    speeds = [v.speed.speed_kmh for v in measured]
    lanes = sorted({v.lane for v in measured if v.lane is not None}) + ([None] if any(v.lane is None for v in measured) else [])
    groups = [[v.speed.speed_kmh for v in measured if v.lane == lane] for lane in lanes]
    labels = [f"lane {lane}: median {np.median(g):.1f} km/h ({len(g)})" if lane is not None else f"no lane ({len(g)})"
              for lane, g in zip(lanes, groups)]
    figure = Figure(figsize=(6.4, 3.6), dpi=120)
    axis = figure.subplots()
    axis.hist(groups or [[]], bins=np.arange(0.0, max(speeds + [60.0]) + 10.0, 5.0), stacked=True, edgecolor="white",
              label=labels or None)
    if labels:
        axis.legend(fontsize=8)
    axis.set_xlabel("speed (km/h)")
    axis.set_ylabel("vehicles")
    axis.set_title(f"{title}: {len(speeds)} measured, {len(vehicles) - len(speeds)} not")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return buffer.getvalue()


def overlay_frames(vehicles: list[VehicleSpeed], count: int) -> list[int]:
    """The `count` frames with the most measured vehicles in view, at least a second apart (25 frames)."""
    seen: dict[int, int] = {}
    for vehicle in vehicles:
        if vehicle.status == SpeedStatus.MEASURED:
            for frame in vehicle.path.frames[vehicle.used]:
                seen[int(frame)] = seen.get(int(frame), 0) + 1
    chosen: list[int] = []
    for frame in sorted(seen, key=lambda f: (-seen[f], f)):
        if all(abs(frame - other) >= 25 for other in chosen):
            chosen.append(frame)
        if len(chosen) == count:
            break
    return sorted(chosen)


OVERLAY_MIN_WIDTH_PX = 960
"""A frame narrower than this is enlarged (by a whole factor) before its labels are drawn, so that they can be read."""


def draw_speeds(frame_bgr: np.ndarray, frame: int, vehicles: list[VehicleSpeed]) -> np.ndarray:
    """The frame with each measured vehicle in view boxed and labelled with its track id and speed (a small frame
    enlarged first)."""
    import cv2

    factor = max(1, int(np.ceil(OVERLAY_MIN_WIDTH_PX / frame_bgr.shape[1])))
    image = cv2.resize(frame_bgr, None, fx=factor, fy=factor, interpolation=cv2.INTER_LINEAR) if factor > 1 else frame_bgr.copy()
    scale = max(0.5, image.shape[0] / 1440)
    for vehicle in vehicles:
        if vehicle.status != SpeedStatus.MEASURED:
            continue
        at = np.flatnonzero(vehicle.path.frames == frame)
        if not len(at):
            continue
        x0, y0, x1, y1 = (int(v) * factor for v in vehicle.path.boxes_px[at[0]])
        cv2.rectangle(image, (x0, y0), (x1 - 1, y1 - 1), (40, 200, 255), max(1, round(2 * scale)))
        label = f"{vehicle.track_id}: {vehicle.speed.speed_kmh:.0f} km/h"
        origin = (x0, max(12, y0 - 5))
        cv2.putText(image, label, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), max(2, round(4 * scale)), cv2.LINE_AA)
        cv2.putText(image, label, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, (40, 200, 255), max(1, round(1.5 * scale)),
                    cv2.LINE_AA)
    return image


def write_overlays(video: str | Path, vehicles: list[VehicleSpeed], out_dir: Path, count: int = OVERLAY_FRAMES) -> list[Path]:
    """`speeds_frame<N>.png` for the frames of `overlay_frames`, read again from the video."""
    wanted, written = overlay_frames(vehicles, count), []
    if not wanted:
        return written
    for index, frame_bgr in enumerate(iter_frames(video)):
        if index in wanted:
            written.append(write_image(out_dir / f"speeds_frame{index}.png", draw_speeds(frame_bgr, index, vehicles)))
        if index >= wanted[-1]:
            break
    return written


def write_speed_files(vehicles: list[VehicleSpeed], calibration: CameraCalibration, out_dir: Path, video: str,
                      fps: float, overlays: bool = True) -> str:
    """Write the vehicles' files into `out_dir` (the frames with their speeds drawn, read again from `video`, with
    `overlays`); a line saying what was written (and why the results file was not, where the camera cannot be written
    in the benchmark's model)."""
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    write_text(out_dir / "tracks.csv", pd.DataFrame([v.row() for v in vehicles]).to_csv(index=False, float_format="%.3f"))
    rows = [row for v in vehicles for row in v.trajectory_rows(calibration.road_to_image)]
    columns = ["track_id", "frame", "time_s", "x_mm", "y_mm", "x_px", "y_px", "used", "predicted"]
    write_text(out_dir / "trajectories.csv", pd.DataFrame(rows, columns=columns).to_csv(index=False, float_format="%.3f"))
    write_bytes(out_dir / "speeds.png", speed_plot(vehicles, Path(video).name))
    if overlays:
        write_overlays(video, vehicles, out_dir)
    measured = [v for v in vehicles if v.status == SpeedStatus.MEASURED]
    unknown = sum(v.model_source == ModelSource.UNKNOWN for v in measured)
    counts = f"{len(vehicles)} vehicle(s), {len(measured)} with a speed" + (
        f" ({unknown} by the bottom of its box: no likely model's size)" if unknown else "")
    block = benchmark_calibration(calibration, vehicles)
    if isinstance(block, str):
        return f"{counts}: {out_dir / 'tracks.csv'} (no {RESULTS_NAME}: {block})"
    write_text(out_dir / RESULTS_NAME, results_json(vehicles, block, calibration.camera.road_to_image(), str(video),
                                                         calibration.image_size_px, fps))
    return f"{counts}: {out_dir / 'tracks.csv'}, {out_dir / RESULTS_NAME}"
