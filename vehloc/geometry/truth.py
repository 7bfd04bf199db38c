"""The ground truth of a rendered traffic scene (`ground_truth.json`, written by `vehloc-scene`), read into
typed objects: the camera, the timing, and for every car what it is, where it stops or crosses, and its
pose and box in every frame. Boxes are converted from the file's 0-based inclusive convention to `Box`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.text import read_json
from vehloc.errors import VehlocError
from vehloc.geometry.camera import PinholeCamera

T = TypeVar("T")


class SceneTruthError(VehlocError):
    """A scene ground-truth file is missing, not JSON, or lacks a key or a well-formed value."""


@dataclass(frozen=True)
class RoadPose:
    """A car's pose on the road: its footprint centre (mm) and heading (deg from +X, counter-clockwise)."""

    x_mm: float
    y_mm: float
    heading_deg: float


@dataclass(frozen=True, eq=False)
class PlateTruth:
    """A licence plate at the car's target pose: corners (4, 3) world mm and (4, 2) px (counter-clockwise
    seen from outside the car, from the lower corner on its right), centre px, whether it faces the camera."""

    corners_mm: np.ndarray
    corners_px: np.ndarray
    centre_px: np.ndarray
    faces_camera: bool


@dataclass(frozen=True, eq=False)
class CarTruth:
    """One car of a scene. Tyre contacts (4, 2) mm: front-left, front-right, rear-left, rear-right; footprint
    corners (4, 2) mm: front-left, front-right, rear-right, rear-left; both at the target pose, where a
    stopping car stops and a passing car is at mid-time. ``axle_middle_x_mm``: where the middle between the
    axles lies along the car, from the footprint's centre towards the front (a specification, with the
    tyres it gives the true pose as the paper measures it). ``poses`` and ``boxes`` hold one entry per frame,
    None while the car is not in the scene (poses) or not in view (boxes). ``plates`` is empty for a car
    rendered without licence plates; ``speed_kmh`` is a passing car's constant speed (None for a stopping one)."""

    model_id: int
    make: str
    model: str
    length_mm: float
    width_mm: float
    height_mm: float
    wheelbase_mm: float
    axle_middle_x_mm: float
    stops: bool
    entry_frame: int
    stop_frame: int | None
    target_pose: RoadPose
    tyre_contacts_mm: np.ndarray
    footprint_corners_mm: np.ndarray
    plates: dict[str, PlateTruth]
    speed_kmh: float | None
    poses: tuple[RoadPose | None, ...]
    boxes: tuple[Box | None, ...]


@dataclass(frozen=True, eq=False)
class SceneTruth:
    """A scene's camera (its image size included), frame rate, frame counts and cars."""

    name: str
    camera: PinholeCamera
    fps: float
    frame_count: int
    empty_frames: int
    cars: tuple[CarTruth, ...]


def _joined(where: str, key: str) -> str:
    """The path of `key` under `where` ("" for the top level)."""
    return f"{where}.{key}" if where else key


class _Reader:
    """Values taken from the parsed file, each failure named by the file and the key's path."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def get(self, mapping: Any, key: str, where: str) -> Any:
        if not isinstance(mapping, dict):
            raise SceneTruthError(f"{self.path}: {where or 'the file'} is not a mapping")
        if key not in mapping:
            raise SceneTruthError(f"{self.path}: missing key {_joined(where, key)}")
        return mapping[key]

    def value(self, mapping: Any, key: str, where: str, convert: Callable[[Any], T]) -> T:
        raw = self.get(mapping, key, where)
        try:
            return convert(raw)
        except KeyError as err:
            raise SceneTruthError(f"{self.path}: missing key {_joined(where, key)}.{err.args[0]}") from None
        except (TypeError, ValueError) as err:
            raise SceneTruthError(f"{self.path}: bad value of {_joined(where, key)}: {err}") from None

    def array(self, mapping: Any, key: str, where: str, shape: tuple[int, ...]) -> np.ndarray:
        def convert(raw: Any) -> np.ndarray:
            array = np.asarray(raw, dtype=float)
            if array.shape != shape:
                raise ValueError(f"expected shape {shape}, got {array.shape}")
            return array

        return self.value(mapping, key, where, convert)


def _boolean(raw: Any) -> bool:
    if not isinstance(raw, bool):
        raise ValueError(f"expected true or false, got {raw!r}")
    return raw


def _pose(raw: Any) -> RoadPose:
    return RoadPose(float(raw["x_mm"]), float(raw["y_mm"]), float(raw["heading_deg"]))


def _box(raw: Any) -> Box:
    x1, y1, x2, y2 = (int(v) for v in raw)
    return Box.from_inclusive(x1, y1, x2, y2)


def _optional(convert: Callable[[Any], T]) -> Callable[[Any], T | None]:
    return lambda raw: None if raw is None else convert(raw)


def _per_frame(convert: Callable[[Any], T], frame_count: int, first_frame: int) -> Callable[[Any], tuple[T | None, ...]]:
    """A list of one entry per frame from `first_frame` on (the car's frames in the scene; None before and after)."""
    def read(raw: Any) -> tuple[T | None, ...]:
        if not isinstance(raw, list) or not 0 <= first_frame <= first_frame + len(raw) <= frame_count:
            raise ValueError(f"expected a list of at most {frame_count - first_frame} frames from frame {first_frame}")
        values = tuple(None if item is None else convert(item) for item in raw)
        return (None,) * first_frame + values + (None,) * (frame_count - first_frame - len(values))

    return read


def _plate(reader: _Reader, raw: Any, where: str) -> PlateTruth:
    return PlateTruth(
        reader.array(raw, "corners_mm", where, (4, 3)),
        reader.array(raw, "corners_px", where, (4, 2)),
        reader.array(raw, "centre_px", where, (2,)),
        reader.value(raw, "faces_camera", where, _boolean),
    )


def _car(reader: _Reader, raw: Any, where: str, frame_count: int) -> CarTruth:
    plates = reader.get(raw, "plates", where)
    first_frame = reader.value(raw, "per_frame_from", where, int) if "per_frame_from" in raw else 0
    return CarTruth(
        model_id=reader.value(raw, "model_id", where, int),
        make=reader.value(raw, "make", where, str),
        model=reader.value(raw, "model", where, str),
        length_mm=reader.value(raw, "length_mm", where, float),
        width_mm=reader.value(raw, "width_mm", where, float),
        height_mm=reader.value(raw, "height_mm", where, float),
        wheelbase_mm=reader.value(raw, "wheelbase_mm", where, float),
        axle_middle_x_mm=reader.value(raw, "axle_middle_x_mm", where, float),
        stops=reader.value(raw, "stops", where, _boolean),
        entry_frame=reader.value(raw, "entry_frame", where, int),
        stop_frame=reader.value(raw, "stop_frame", where, _optional(int)),
        target_pose=reader.value(raw, "target_pose", where, _pose),
        tyre_contacts_mm=reader.array(raw, "tyre_contacts_mm", where, (4, 2)),
        footprint_corners_mm=reader.array(raw, "footprint_corners_mm", where, (4, 2)),
        plates={end: _plate(reader, reader.get(plates, end, f"{where}.plates"), f"{where}.plates.{end}")
                for end in (("front", "rear") if plates else ())},
        speed_kmh=reader.value(raw, "speed_kmh", where, _optional(float)) if "speed_kmh" in raw else None,
        poses=reader.value(raw, "poses", where, _per_frame(_pose, frame_count, first_frame)),
        boxes=reader.value(raw, "boxes_xyxy_px", where, _per_frame(_box, frame_count, first_frame)),
    )


def read_scene_truth(path: str | Path) -> SceneTruth:
    """Read a scene's `ground_truth.json`; SceneTruthError naming the file (and key) when it is missing,
    not JSON, or lacks what is read here."""
    path = Path(path)
    if not path.is_file():
        raise SceneTruthError(f"{path}: scene ground truth does not exist")
    raw = read_json(path, SceneTruthError)
    reader = _Reader(path)
    camera_raw = reader.get(raw, "camera", "")
    camera = PinholeCamera(
        K=reader.array(camera_raw, "K", "camera", (3, 3)),
        R=reader.array(camera_raw, "R_world_to_camera", "camera", (3, 3)),
        t=reader.array(camera_raw, "t_mm", "camera", (3,)),
        width_px=reader.value(camera_raw, "width_px", "camera", int),
        height_px=reader.value(camera_raw, "height_px", "camera", int),
    )
    frame_count = reader.value(raw, "frames", "", int)
    cars_raw = reader.get(raw, "cars", "")
    if not isinstance(cars_raw, list) or not cars_raw:
        raise SceneTruthError(f"{path}: cars must be a non-empty list")
    return SceneTruth(
        name=reader.value(raw, "scene", "", str),
        camera=camera,
        fps=reader.value(raw, "fps", "", float),
        frame_count=frame_count,
        empty_frames=reader.value(raw, "empty_frames", "", int),
        cars=tuple(_car(reader, car, f"cars[{i}]", frame_count) for i, car in enumerate(cars_raw)),
    )
