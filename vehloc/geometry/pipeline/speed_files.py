"""A video's vehicles as files: `tracks.csv` (one row per vehicle), `trajectories.csv` (one row per vehicle per
frame), `system_vehloc.json` (the speed benchmark's results format) and `speeds.png` (their distribution)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.atomic import write_bytes, write_text
from vehloc.geometry.brno import BrnoCalibration, brno_calibration
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.pipeline.brno_files import RESULTS_NAME, results_json
from vehloc.geometry.pipeline.track_speed import SpeedStatus, VehicleSpeed

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
    """A histogram of the measured speeds, with the vehicles not measured counted in the legend."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    speeds = [v.speed.speed_kmh for v in vehicles if v.status == SpeedStatus.MEASURED]
    figure, axis = plt.subplots(figsize=(6.4, 3.6), dpi=120)
    axis.hist(speeds, bins=np.arange(0.0, max(speeds + [60.0]) + 10.0, 5.0), color="#3870a8", edgecolor="white")
    axis.set_xlabel("speed (km/h)")
    axis.set_ylabel("vehicles")
    axis.set_title(f"{title}: {len(speeds)} measured, {len(vehicles) - len(speeds)} not")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    return buffer.getvalue()


def write_speed_files(vehicles: list[VehicleSpeed], calibration: CameraCalibration, out_dir: Path, video: str) -> str:
    """Write the vehicles' files into `out_dir`; a line saying what was written (and why the results file was not,
    where the camera cannot be written in the benchmark's model)."""
    write_text(out_dir / "tracks.csv", pd.DataFrame([v.row() for v in vehicles]).to_csv(index=False, float_format="%.3f"))
    rows = [row for v in vehicles for row in v.trajectory_rows()]
    columns = ["track_id", "frame", "time_s", "x_mm", "y_mm", "x_px", "y_px", "used"]
    write_text(out_dir / "trajectories.csv", pd.DataFrame(rows, columns=columns).to_csv(index=False, float_format="%.3f"))
    write_bytes(out_dir / "speeds.png", speed_plot(vehicles, Path(video).name))
    measured = sum(v.status == SpeedStatus.MEASURED for v in vehicles)
    block = benchmark_calibration(calibration, vehicles)
    if isinstance(block, str):
        return f"{len(vehicles)} vehicle(s), {measured} with a speed: {out_dir / 'tracks.csv'} (no {RESULTS_NAME}: {block})"
    write_text(out_dir / RESULTS_NAME, results_json(vehicles, block, calibration.camera.road_to_image(), str(video),
                                                         calibration.image_size_px))
    return f"{len(vehicles)} vehicle(s), {measured} with a speed: {out_dir / 'tracks.csv'}, {out_dir / RESULTS_NAME}"
