"""A camera from what traffic shows it, no survey: the focal length and the road's orientation from the vanishing
points of the road's two directions (Dubská et al.), the camera's height (the scene's scale) from the recognised
vehicles' shapes (as Sochor et al.'s BBScale aligns 3D models to the vehicles' boxes).

World frame of an automatic calibration: the camera's foot at the origin, Y along the traffic's direction (the first
vanishing point, the way the camera looks), X across it to the right, Z up: vehloc's road frame, placed at the camera.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import shape_points_world
from vehloc.geometry.outcome import FailedEstimate
from vehloc.geometry.placement import VehicleBox

NEWTON_ITERATIONS = 10
TOLERANCE = 1e-4
START_SHRINKS = tuple(np.geomspace(0.1, 10.0, 11))
"""Where the shrink factor (the camera's assumed height over its true one) may start."""


def focal_from_vanishing_points(vp1_h: np.ndarray, vp2_h: np.ndarray, pp_px: np.ndarray) -> float | FailedEstimate:
    """The focal length (px) that makes the two homogeneous vanishing points those of perpendicular directions, the
    principal point `pp_px` and the pixels square; a `FailedEstimate` when none does."""
    a1, a2 = (np.asarray(v[:2], float) - v[2] * np.asarray(pp_px, float) for v in (vp1_h, vp2_h))
    w = float(vp1_h[2] * vp2_h[2])
    if abs(w) < 1e-15 * max(np.linalg.norm(a1) * np.linalg.norm(a2), 1e-300):
        return FailedEstimate("a vanishing point is at infinity: the focal length cannot be told from the two")
    focal_squared = -float(a1 @ a2) / w
    if not focal_squared > 0.0:
        return FailedEstimate("the vanishing points are not those of two perpendicular road directions "
                              "(no real focal length)")
    return float(np.sqrt(focal_squared))


def camera_from_vanishing_points(vp1_h: np.ndarray, vp2_h: np.ndarray, pp_px: np.ndarray, height_mm: float,
                                 image_size_px: tuple[int, int]) -> PinholeCamera | FailedEstimate:
    """The camera `height_mm` above the road whose vanishing points of the road's along (`vp1_h`) and across
    (`vp2_h`) directions are those given (homogeneous px), in the automatic calibration's world frame."""
    focal = focal_from_vanishing_points(vp1_h, vp2_h, pp_px)
    if isinstance(focal, FailedEstimate):
        return focal
    return camera_from_horizon(vp1_h, horizon_through(vp1_h, vp2_h), pp_px, focal, height_mm, image_size_px)


def horizon_through(vp1_h: np.ndarray, vp2_h: np.ndarray) -> np.ndarray:
    """The horizon's line (homogeneous) through the first vanishing point towards the second, finite or not."""
    return np.cross(np.asarray(vp1_h, float), np.asarray(vp2_h, float))


def camera_from_horizon(vp1_h: np.ndarray, horizon_h: np.ndarray, pp_px: np.ndarray, focal_px: float,
                        height_mm: float, image_size_px: tuple[int, int]) -> PinholeCamera:
    """The camera `height_mm` above the road with focal length `focal_px` whose road has the along direction's
    vanishing point `vp1_h` and the horizon `horizon_h` (a homogeneous line through it): the road's normal is the
    horizon's plane through the camera centre, so a focal length known from the lens needs no second point."""
    K = PinholeCamera.intrinsics(focal_px, *image_size_px, principal_px=(float(pp_px[0]), float(pp_px[1])))
    along = np.linalg.inv(K) @ np.asarray(vp1_h, float)
    along = along / np.linalg.norm(along) * (1.0 if along[2] >= 0 else -1.0)
    up = K.T @ np.asarray(horizon_h, float)
    up = up - (up @ along) * along
    up = up / np.linalg.norm(up)
    up = up if up[1] < 0 else -up  # the road's normal points up the image
    right = np.cross(along, up)
    return camera_at_height(PinholeCamera(K, np.column_stack([right, along, up]), np.zeros(3), *image_size_px),
                            height_mm)


def camera_at_height(camera: PinholeCamera, height_mm: float) -> PinholeCamera:
    """The same camera moved up or down its vertical to `height_mm` above the road (the scene scaled)."""
    return PinholeCamera(camera.K, camera.R, -camera.R @ np.array([0.0, 0.0, height_mm]), camera.width_px,
                         camera.height_px)


@dataclass(frozen=True)
class BoxScale:
    """One view's estimate: the camera height (mm) at which the shape's box has the vehicle's top, left and right
    edges, its footprint centre there (mm) and how far the vehicle's bottom is below the shape's (px)."""

    height_mm: float
    centre_mm: np.ndarray
    bottom_gap_px: float


def box_sides_px(points_px: np.ndarray) -> np.ndarray:
    """Top row, left and right columns of the box of pixels the projected points cover at least half."""
    return np.array([points_px[:, 1].min() + 0.5, points_px[:, 0].min() + 0.5, points_px[:, 0].max() - 0.5])


def height_from_sides(camera: PinholeCamera, shape: VehicleShape, sides_px: np.ndarray, bottom_px: float,
                      heading_deg: float) -> BoxScale | FailedEstimate:
    """The camera height at which the vehicle's `shape`, heading `heading_deg` along the road, has the vehicle's top
    row, left and right columns `sides_px` (as `box_sides_px`), by Newton's method on (centre, 1/scale) in the frame of
    `camera` (any height: the scene scales about the camera's foot), started from the road point under the middle of
    the bottom row `bottom_px` and the best of a few shrink factors; a `FailedEstimate` when it does not converge."""
    points_car = shape_points_world(shape, VehicleBox(np.zeros(2), heading_deg, 0.0, 0.0))  # around its centre
    camera_height = float(camera.centre_mm[2])
    target = np.asarray(sides_px, dtype=float)
    bottom_road = camera.image_to_road(np.array([[(target[1] + target[2]) / 2, bottom_px]]))[0]
    unknowns = np.array([bottom_road[0], bottom_road[1], 1.0])  # centre (mm, this camera's frame), shrink factor

    def sides(x: np.ndarray) -> np.ndarray:
        world = points_car * x[2] + [x[0], x[1], 0.0]
        pixels = camera.project(world)
        return box_sides_px(pixels) if np.all(np.isfinite(pixels)) else np.full(3, np.nan)

    residuals = [np.linalg.norm(sides(np.array([*bottom_road, k])) - target) for k in START_SHRINKS]
    residuals = [r if np.isfinite(r) else np.inf for r in residuals]
    unknowns[2] = START_SHRINKS[int(np.argmin(residuals))]
    steps = np.array([10.0, 10.0, 1e-3])
    for _ in range(NEWTON_ITERATIONS):
        here = sides(unknowns)
        jacobian = np.column_stack([(sides(unknowns + np.eye(3)[k] * steps[k]) - here) / steps[k] for k in range(3)])
        if not (np.all(np.isfinite(jacobian)) and np.all(np.isfinite(here))) or abs(np.linalg.det(jacobian)) < 1e-15:
            break
        move = np.linalg.solve(jacobian, target - here)
        unknowns = unknowns + move
        if unknowns[2] <= 0:
            break
        if abs(move[2]) < TOLERANCE * unknowns[2] and np.linalg.norm(move[:2]) < 1.0:
            pixels = camera.project(points_car * unknowns[2] + [unknowns[0], unknowns[1], 0.0])
            bottom_gap = float(bottom_px - (pixels[:, 1].max() - 0.5))
            foot = camera.centre_mm[:2]
            return BoxScale(camera_height / unknowns[2], foot + (unknowns[:2] - foot) / unknowns[2], bottom_gap)
    return FailedEstimate("no camera height puts the model's box where the vehicle's is")


@dataclass(frozen=True)
class RobustScale:
    """The camera height combined over vehicles: the median of their estimates (mm), its 1-sigma from their spread
    and from the classifier's doubt about their models, and how many vehicles gave it."""

    height_mm: float
    sigma_spread_mm: float
    sigma_classifier_mm: float
    vehicles: int

    @property
    def sigma_mm(self) -> float:
        return float(np.hypot(self.sigma_spread_mm, self.sigma_classifier_mm))

    @property
    def sigma_fraction(self) -> float:
        return self.sigma_mm / self.height_mm


def combine_heights(heights_mm: np.ndarray, doubt_fractions: np.ndarray) -> RobustScale:
    """The median of the vehicles' heights, its 1-sigma from their median absolute deviation (x 1.4826, the
    median's efficiency 1.2533, over the square root of their count) and from each vehicle's relative doubt about
    its model's size (`doubt_fractions`, averaged in quadrature over the count)."""
    heights = np.asarray(heights_mm, dtype=float)
    n = len(heights)
    median = float(np.median(heights))
    mad = float(np.median(np.abs(heights - median)))
    spread = 1.4826 * mad * 1.2533 / np.sqrt(n)
    classifier = median * float(np.sqrt(np.mean(np.asarray(doubt_fractions, float) ** 2)) / np.sqrt(n))
    return RobustScale(median, spread, classifier, n)
