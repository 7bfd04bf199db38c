"""The shadow a vehicle's shape casts on the road under a distant sun, in the model fit's silhouette grid: each
point of the shape moved along the road, away from the sun, by its height times the sun's elevation's cotangent
(`sun_cast`), each part's shadow the convex hull of its points'; and the cast whose shadow best explains an ROI's
dark pixels (`fit_cast`)."""

from __future__ import annotations

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import filled_parts, shape_points_world, silhouette
from vehloc.geometry.placement import VehicleBox

CAST_DIRECTIONS = 16
CAST_LENGTHS = (0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.2, 3.0)
"""The casts `fit_cast` tries: these lengths (road mm per mm of height: the sun 84 to 18 deg high) in 16 directions."""


def sun_cast(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """The road offset (mm per mm of height) of a shadow cast by a sun at `azimuth_deg` (from world +X,
    counter-clockwise) and `elevation_deg` above the road: away from the sun, the elevation's cotangent long."""
    if not 0.0 < elevation_deg <= 90.0:
        raise ValueError(f"elevation_deg must be in (0, 90], got {elevation_deg}")
    azimuth = np.radians(azimuth_deg)
    return -np.array([np.cos(azimuth), np.sin(azimuth)]) / np.tan(np.radians(elevation_deg))


def cast_shadow(camera: PinholeCamera, shape: VehicleShape, box: VehicleBox, cast: np.ndarray, roi: Box,
                supersample: int) -> np.ndarray:
    """The road pixels in the shadow of `shape` at `box` under the sun of `cast` (`sun_cast`), as `silhouette`'s mask
    (the vehicle itself not taken out)."""
    world = shape_points_world(shape, box)
    on_road = np.column_stack([world[:, :2] + world[:, 2:3] * np.asarray(cast, float)[None, :2], np.zeros(len(world))])
    return filled_parts(camera, shape, on_road, roi, supersample)


def fit_cast(camera: PinholeCamera, shape: VehicleShape, box: VehicleBox, roi: Box, dark: np.ndarray,
             supersample: int, max_cast: float = CAST_LENGTHS[-1]) -> np.ndarray:
    """The cast whose shadow of the shape at `box`, with the shape, best overlaps (IoU) the shape and the `dark`
    pixels (bool, on the supersampled grid): `CAST_LENGTHS` up to `max_cast` in `CAST_DIRECTIONS` directions, and
    none (0, 0) when no shadow overlaps better than the shape alone."""
    car = silhouette(camera, shape, box, roi, supersample)
    wanted = (car | dark).view(np.uint8)
    wanted_px = cv2.countNonZero(wanted)

    def score(cast: np.ndarray) -> float:
        predicted = (car | cast_shadow(camera, shape, box, cast, roi, supersample)).view(np.uint8)
        common = cv2.countNonZero(predicted & wanted)
        return common / (cv2.countNonZero(predicted) + wanted_px - common)

    angles = np.radians(np.arange(CAST_DIRECTIONS) * 360.0 / CAST_DIRECTIONS)
    casts = [np.zeros(2)] + [length * np.array([np.cos(a), np.sin(a)])
                             for length in CAST_LENGTHS if length <= max_cast for a in angles]
    return casts[int(np.argmax([score(cast) for cast in casts]))]
