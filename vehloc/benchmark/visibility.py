"""What of a stopped car a camera can see, from the scene's exact geometry: whether a licence plate is in view
(carried, its face turned to the camera, wholly in the image and wide enough to read as a plate) and which
tyres are (their outer face turned to the camera enough to show the rim, wholly in the image, tall enough).
The thresholds are the benchmark's (`visibility:` of `conf/localization_benchmark.yaml`), not the detectors'."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.config import check_range
from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.catalog import CarModel
from vehloc.synth.render import CarPose, plates_seen, tyre_contacts_car_mm

TYRE_NAMES = ("front_left", "front_right", "rear_left", "rear_right")


@dataclass(frozen=True)
class VisibilityParams:
    """When a plate or a tyre counts as visible."""

    plate_min_width_px: float
    plate_min_facing: float
    tyre_min_facing: float
    tyre_min_diameter_px: float

    def __post_init__(self) -> None:
        check_range("plate_min_width_px", self.plate_min_width_px, 0.0)
        check_range("plate_min_facing", self.plate_min_facing, 0.0, 1.0)
        check_range("tyre_min_facing", self.tyre_min_facing, 0.0, 1.0)
        check_range("tyre_min_diameter_px", self.tyre_min_diameter_px, 0.0)


@dataclass(frozen=True)
class Visibility:
    """The truth of what is visible: the plate seen (`front`, `rear` or None) and each tyre (front-left,
    front-right, rear-left, rear-right)."""

    plate_end: str | None
    tyres: tuple[bool, bool, bool, bool]

    @property
    def plate(self) -> bool:
        return self.plate_end is not None

    @property
    def two_tyres(self) -> bool:
        """Both tyres of one side are visible (what the paper's wheel branch needs)."""
        left, right = self.tyres[0] and self.tyres[2], self.tyres[1] and self.tyres[3]
        return left or right

    @property
    def key_points(self) -> bool:
        """The plate or two tyres of a side are visible: the paper's key points should be found."""
        return self.plate or self.two_tyres


def facing(outward: np.ndarray, point_mm: np.ndarray, camera: PinholeCamera) -> float:
    """The cosine between a face's outward normal and the direction from the face to the camera."""
    sight = camera.centre_mm - point_mm
    return float(outward @ sight / np.linalg.norm(sight))


def inside(pixels: np.ndarray, camera: PinholeCamera) -> bool:
    return bool(np.all(np.isfinite(pixels)) and pixels[:, 0].min() >= 0 and pixels[:, 1].min() >= 0
                and pixels[:, 0].max() <= camera.width_px - 1 and pixels[:, 1].max() <= camera.height_px - 1)


def visible_plate(model: CarModel, pose: CarPose, camera: PinholeCamera, params: VisibilityParams) -> str | None:
    """The end (`front` or `rear`) whose plate the camera sees, None when neither."""
    for end, plate in plates_seen(model, pose, camera).items():
        outward = pose.rotation @ np.array([1.0 if end == "front" else -1.0, 0.0, 0.0])
        width_px = float(np.linalg.norm(plate.corners_px[1] - plate.corners_px[0]))  # the lower edge
        if (facing(outward, plate.centre_mm, camera) >= params.plate_min_facing and inside(plate.corners_px, camera)
                and width_px >= params.plate_min_width_px):
            return end
    return None


def visible_tyres(model: CarModel, pose: CarPose, camera: PinholeCamera, params: VisibilityParams) -> tuple[bool, ...]:
    """Per tyre (front-left, front-right, rear-left, rear-right): whether its rim shows (the outer face turned
    to the camera by at least `tyre_min_facing`, the wheel wholly in the image, `tyre_min_diameter_px` tall)."""
    radius_mm = model.shape.wheel_radius_mm
    seen = []
    for contact in tyre_contacts_car_mm(model):
        side = np.sign(contact[1])
        centre = pose.car_to_world((contact + [0.0, side * model.shape.tyre_width_mm / 2, radius_mm])[None])[0]
        outward = pose.rotation @ np.array([0.0, side, 0.0])
        rim = centre + np.array([[0.0, 0.0, -radius_mm], [0.0, 0.0, radius_mm]])
        ends = pose.car_to_world(contact[None] + np.array([[radius_mm, 0.0, radius_mm], [-radius_mm, 0.0, radius_mm]]))
        pixels = camera.project(np.vstack([rim, ends]))
        tall_px = float(np.linalg.norm(pixels[1] - pixels[0])) if np.all(np.isfinite(pixels[:2])) else 0.0
        seen.append(facing(outward, centre, camera) >= params.tyre_min_facing and inside(pixels, camera)
                    and tall_px >= params.tyre_min_diameter_px)
    return tuple(seen)


def visibility(model: CarModel, pose: CarPose, camera: PinholeCamera, plates: bool, params: VisibilityParams) -> Visibility:
    """What `camera` sees of `model` standing at `pose` (carrying licence plates or not)."""
    plate_end = visible_plate(model, pose, camera, params) if plates else None
    return Visibility(plate_end, visible_tyres(model, pose, camera, params))
