"""What a box's bottom is on the road: the background model's box of a vehicle ends at the lowest pixel of its
silhouette, which is not the vehicle's centre, and not even on the road (a bumper's lower edge stands a few hundred
millimetres above it; seen from a camera H mm up, a point h mm high lands on the road H / (H - h) times as far from
the camera's foot, so a path of such points runs that much too fast). Given the recognised model's shape and the
heading of its path, the footprint centre whose projected shape has its box's bottom where the vehicle's has is
the vehicle's reference point on the road."""

from __future__ import annotations

import numpy as np

from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import shape_points_world
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.projective import ProjectiveTransform

BOTTOM_ITERATIONS = 6
BOTTOM_TOLERANCE_MM = 1.0


def box_bottom_px(camera: PinholeCamera, shape: VehicleShape, centre_mm: np.ndarray, heading_deg: float) -> np.ndarray:
    """The pixel the pipeline takes as a box's bottom (its middle column, its lowest row's centre: `y1 - 1` of an
    exclusive box) for the shape standing at `centre_mm` with `heading_deg`; NaN where part of it is behind the
    camera."""
    pixels = camera.project(shape_points_world(shape, VehicleBox(np.asarray(centre_mm, float), heading_deg, 0.0, 0.0)))
    if not np.all(np.isfinite(pixels)):
        return np.full(2, np.nan)
    return np.array([(pixels[:, 0].min() + pixels[:, 0].max()) / 2, pixels[:, 1].max() - 0.5])


def centre_under_box_bottom(camera: PinholeCamera, road_to_image: ProjectiveTransform, shape: VehicleShape,
                            bottom_mm: np.ndarray, heading_deg: float) -> np.ndarray | NotPlaced:
    """The footprint centre (mm) at which the shape, heading `heading_deg`, has its box's bottom at the road point
    `bottom_mm` (the road point under the observed box's bottom): a fixed-point iteration, each step moving the
    centre by what its predicted bottom misses; a `NotPlaced` when it does not settle."""
    target = np.asarray(bottom_mm, dtype=float)
    image_to_road = road_to_image.inverse
    centre = target.copy()
    for _ in range(BOTTOM_ITERATIONS):
        predicted_px = box_bottom_px(camera, shape, centre, heading_deg)
        if not np.all(np.isfinite(predicted_px)):
            break
        predicted_mm = image_to_road(predicted_px[None])[0]
        miss = target - predicted_mm
        centre = centre + miss
        if float(np.linalg.norm(miss)) < BOTTOM_TOLERANCE_MM:
            return centre
    return NotPlaced(ReasonCode.ON_HORIZON, "the shape's box bottom cannot be matched to the vehicle's")
