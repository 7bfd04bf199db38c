"""The speed benchmark's files (BrnoCompSpeed): a system's results (`system_<name>.json`: the camera calibration
block and every car's image points on the road per frame) and a video's ground truth (`gt_data.pkl`, a Python-2
pickle, or the same fields as JSON). Each reader checks what the scorer uses and names the file and the field that is
missing or wrong."""

from __future__ import annotations

import json
import pickle
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vehloc.errors import VehlocError
from vehloc.geometry.brno import BrnoCalibration
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.pipeline.track_speed import SpeedStatus, VehicleSpeed

GROUND_TRUTH_FIELDS = ("fps", "measurementLines", "laneDivLines", "invalidLanes", "distanceMeasurement", "cars")
CAR_FIELDS = ("carId", "laneIndex", "intersections", "speed", "valid")
RESULTS_NAME = "system_vehloc.json"


class BrnoFileError(VehlocError):
    """A benchmark file is missing, unreadable or lacks a field the scorer uses."""


@dataclass(frozen=True)
class BrnoCar:
    """A system's car: its id and its image points on the road, frame by frame."""

    car_id: int
    frames: np.ndarray
    points_px: np.ndarray


@dataclass(frozen=True)
class BrnoResults:
    """A system's results for one video."""

    calibration: BrnoCalibration
    cars: tuple[BrnoCar, ...]
    video: str | None = None
    image_size_px: tuple[int, int] | None = None
    fps: float | None = None


@dataclass(frozen=True)
class GroundTruthCar:
    """A car of the ground truth: its id, lanes, the video times (s) it crossed the measurement lines, its speed
    (km/h) and whether it counts."""

    car_id: int
    lanes: frozenset[int]
    crossing_times_s: tuple[float, ...]
    speed_kmh: float
    valid: bool


@dataclass(frozen=True)
class DistanceMeasurement:
    """A distance on the road between two image points (m), and whether it runs towards the first vanishing point."""

    p1_px: np.ndarray
    p2_px: np.ndarray
    distance_m: float
    to_vp1: bool


@dataclass(frozen=True)
class GroundTruth:
    """A video's ground truth: frame rate, measurement and lane-dividing lines (homogeneous image lines), the
    lanes not evaluated, the measured distances and the cars."""

    fps: float
    measurement_lines: np.ndarray
    lane_lines: np.ndarray
    invalid_lanes: frozenset[int]
    distances: tuple[DistanceMeasurement, ...]
    cars: tuple[GroundTruthCar, ...]
    source: str
    video: str | None = None


def results_json(vehicles: list[VehicleSpeed], calibration: BrnoCalibration, road_to_image: ProjectiveTransform,
                 video: str, image_size_px: tuple[int, int], fps: float) -> str:
    """The results file of a video: every vehicle with a speed, its road points as image points (`posX`, `posY`,
    mapped by `road_to_image`: the pinhole camera the calibration block describes, so that the scorer's projection
    gives them back) per frame it was followed in (`frames`; `VehicleSpeed.reported`); beside the
    benchmark's fields, the video, its image size and frame rate."""
    cars = []
    for v in (v for v in vehicles if v.status == SpeedStatus.MEASURED):
        frames, points_mm = v.reported(road_to_image)
        pixels = road_to_image(points_mm) if len(frames) else np.zeros((0, 2))
        if len(frames):
            cars.append({"id": int(v.track_id), "frames": [int(f) for f in frames],
                         "posX": [float(p[0]) for p in pixels], "posY": [float(p[1]) for p in pixels]})
    return json.dumps({"camera_calibration": calibration.to_json(), "cars": cars, "video": video,
                       "image_size_px": list(image_size_px), "fps": fps}) + "\n"


def _load(path: Path, what: str) -> Any:
    if not path.is_file():
        raise BrnoFileError(f"{path}: {what} does not exist")
    try:
        if path.suffix == ".pkl":
            with path.open("rb") as handle:
                return pickle.load(handle, encoding="latin1")
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, pickle.UnpicklingError, EOFError, UnicodeDecodeError) as err:
        raise BrnoFileError(f"{path}: not a readable {what} ({type(err).__name__}: {err})") from None


def _field(mapping: Any, key: str, where: str, path: Path) -> Any:
    if not isinstance(mapping, dict) or key not in mapping:
        raise BrnoFileError(f"{path}: {where}{key} is missing")
    return mapping[key]


def _lines(raw: Any, key: str, path: Path, at_least: int) -> np.ndarray:
    lines = np.asarray(raw, dtype=float) if isinstance(raw, (list, tuple, np.ndarray)) else np.zeros(0)
    if lines.ndim != 2 or lines.shape[1] != 3 or len(lines) < at_least or not np.all(np.isfinite(lines)):
        raise BrnoFileError(f"{path}: {key} must be at least {at_least} homogeneous image lines [a, b, c]")
    return lines


def read_ground_truth(path: str | Path) -> GroundTruth:
    """A video's ground truth (`.pkl` as the benchmark ships it, else JSON with the same fields)."""
    path = Path(path)
    raw = _load(path, "speed ground truth")
    for key in GROUND_TRUTH_FIELDS:
        _field(raw, key, "", path)
    fps = raw["fps"]
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or not fps > 0:
        raise BrnoFileError(f"{path}: fps must be a positive number, got {fps!r}")
    cars = []
    for index, car in enumerate(raw["cars"]):
        where = f"cars[{index}]."
        for key in CAR_FIELDS:
            _field(car, key, where, path)
        times = [float(_field(i, "videoTime", f"{where}intersections[].", path)) for i in car["intersections"]]
        if not times:
            raise BrnoFileError(f"{path}: {where}intersections is empty")
        cars.append(GroundTruthCar(int(car["carId"]), frozenset(int(lane) for lane in car["laneIndex"]), tuple(times),
                                   float(car["speed"]), bool(car["valid"])))
    if not cars:
        raise BrnoFileError(f"{path}: cars is empty")
    distances = []
    for index, item in enumerate(raw["distanceMeasurement"]):
        where = f"distanceMeasurement[{index}]."
        distances.append(DistanceMeasurement(
            np.asarray(_field(item, "p1", where, path), dtype=float)[:2],
            np.asarray(_field(item, "p2", where, path), dtype=float)[:2],
            float(_field(item, "distance", where, path)), bool(_field(item, "toVP1", where, path))))
    return GroundTruth(float(fps), _lines(raw["measurementLines"], "measurementLines", path, 2),
                       _lines(raw["laneDivLines"], "laneDivLines", path, 2),
                       frozenset(int(lane) for lane in raw["invalidLanes"]), tuple(distances), tuple(cars), str(path),
                       raw.get("video"))


def read_results(path: str | Path) -> BrnoResults:
    """A system's results file."""
    path = Path(path)
    raw = _load(path, "speed results")
    block = _field(raw, "camera_calibration", "", path)
    try:
        calibration = BrnoCalibration(*(tuple(float(v) for v in _field(block, key, "camera_calibration.", path)[:2])
                                        for key in ("vp1", "vp2", "pp")),
                                      float(_field(block, "scale", "camera_calibration.", path)))
    except (TypeError, ValueError) as err:
        raise BrnoFileError(f"{path}: camera_calibration is not vp1, vp2, pp as [x, y] and a scale ({err})") from None
    cars = []
    for index, car in enumerate(_field(raw, "cars", "", path)):
        where = f"cars[{index}]."
        frames, xs, ys = (_field(car, key, where, path) for key in ("frames", "posX", "posY"))
        if not (isinstance(xs, list) and isinstance(ys, list) and len(frames) == len(xs) == len(ys)):
            raise BrnoFileError(f"{path}: {where}frames, posX and posY must be lists of one length")
        cars.append(BrnoCar(int(_field(car, "id", where, path)), np.asarray(frames, dtype=float),
                            np.column_stack([np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)]).reshape(-1, 2)))
    size, fps = raw.get("image_size_px"), raw.get("fps")
    return BrnoResults(calibration, tuple(cars), raw.get("video"), tuple(int(v) for v in size) if size else None,
                       float(fps) if fps else None)
