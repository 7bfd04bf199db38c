"""The model fit, beyond the paper: with the full camera (K, R, t) from the calibration and the predicted
model's shape (its convex parts, or the cuboid of its length, width and height), find the pose (x, y,
heading) whose projected silhouette best overlaps the vehicle's foreground. Starts from the paper's
placement; the overlap compares how much of each pixel the shape covers (drawn on a supersampled grid, so
that it varies smoothly enough for Nelder-Mead) with how much the vehicle weighs there (less where a pixel
may be shadow, the share the vehicle covers along its outline)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_range, params_from_config
from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.placement import VehicleBox, heading_difference_deg

SUBPIXEL_SHIFT = 4


MAX_SUPERSAMPLE = 8
"""The finest silhouette comparison: 8x the image's resolution (64 times its pixels) per evaluation."""
MAX_EVALUATIONS = 10_000
"""The most silhouette evaluations one fit may take (one is about half a millisecond to a few)."""
MAX_SHADOW_PASSES = 5
"""The most rounds of fitting the road's shadow and refitting the vehicle without it."""
MIN_SHADOW_GRID_PX, MAX_SHADOW_GRID_PX = 16, 1024
"""The coarsest and finest grid (its longer side) the road's shadow is fitted on."""
MAX_SHADOW_EDGE_BAND_PX = 16
"""The widest band about the fitted outline whose shaded pixels are read against the shadowed road."""


@dataclass(frozen=True)
class FitParams:
    """Settings of the model fit (`conf/localize/fit/default.yaml`)."""

    supersample: int
    min_grid_px: int
    start_step_mm: float
    start_step_deg: float
    tolerance_mm: float
    tolerance_deg: float
    max_evaluations: int
    try_reversed: bool
    shadow_passes: int
    shadow_ratio_tolerance: float
    shadow_min_darkening: float
    shadow_grid_px: int
    shadow_max_evaluations: int
    shadow_car_margin_px: int
    shadow_edge_band_px: int
    shadow_edge_min_difference: float
    shadow_edge_undecided_weight: float
    shadow_restart_mm: float
    shadow_restart_below: float

    def __post_init__(self) -> None:
        check_range("supersample", self.supersample, 1, MAX_SUPERSAMPLE)
        check_range("min_grid_px", self.min_grid_px, 0)
        for name in ("start_step_mm", "start_step_deg", "tolerance_mm", "tolerance_deg"):
            check_range(name, getattr(self, name), 0.0, low_open=True)
        check_range("max_evaluations", self.max_evaluations, 1, MAX_EVALUATIONS)
        check_range("shadow_passes", self.shadow_passes, 0, MAX_SHADOW_PASSES)
        check_range("shadow_ratio_tolerance", self.shadow_ratio_tolerance, 0.0, 1.0, low_open=True)
        check_range("shadow_min_darkening", self.shadow_min_darkening, 0.0, 1.0, low_open=True)
        check_range("shadow_grid_px", self.shadow_grid_px, MIN_SHADOW_GRID_PX, MAX_SHADOW_GRID_PX)
        check_range("shadow_max_evaluations", self.shadow_max_evaluations, 1, MAX_EVALUATIONS)
        check_range("shadow_car_margin_px", self.shadow_car_margin_px, 0, MAX_SHADOW_EDGE_BAND_PX)
        check_range("shadow_edge_band_px", self.shadow_edge_band_px, 0, MAX_SHADOW_EDGE_BAND_PX)
        check_range("shadow_edge_min_difference", self.shadow_edge_min_difference, 0.0, 1.0)
        check_range("shadow_edge_undecided_weight", self.shadow_edge_undecided_weight, 0.0, 1.0)
        check_range("shadow_restart_mm", self.shadow_restart_mm, 0.0)
        check_range("shadow_restart_below", self.shadow_restart_below, 0.0, 1.0)

    def supersample_for(self, roi: Box) -> int:
        """The grid's multiple of the image resolution over `roi`: `supersample`, or more (up to `MAX_SUPERSAMPLE`)
        where the ROI's longer side would span fewer than `min_grid_px` grid pixels (a far vehicle, a few dozen pixels
        long, whose pose is wanted to a fraction of a pixel)."""
        long_side_px = max(roi.width_px, roi.height_px, 1)
        return int(min(MAX_SUPERSAMPLE, max(self.supersample, -(-self.min_grid_px // long_side_px))))

    @classmethod
    def from_config(cls, **overrides: object) -> FitParams:
        """The settings of `conf/localize/fit/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/fit/default.yaml", overrides)


@dataclass(frozen=True)
class ModelFit:
    """The fitted footprint, the overlap it reaches and the silhouette evaluations it took."""

    box: VehicleBox
    iou: float
    evaluations: int


def shape_points_world(shape: VehicleShape, box: VehicleBox) -> np.ndarray:
    """The shape's points (all parts, as `shape.points_mm`) placed at the box's centre and heading, world mm."""
    c, s = np.cos(np.radians(box.heading_deg)), np.sin(np.radians(box.heading_deg))
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return shape.points_mm @ rotation.T + [box.centre_mm[0], box.centre_mm[1], 0.0]


def silhouette(camera: PinholeCamera, shape: VehicleShape, box: VehicleBox, roi: Box, supersample: int) -> np.ndarray:
    """The shape's silhouette at `box` inside `roi`, as a (roi height, roi width) x `supersample` bool mask."""
    return filled_parts(camera, shape, shape_points_world(shape, box), roi, supersample)


def filled_parts(camera: PinholeCamera, shape: VehicleShape, world_mm: np.ndarray, roi: Box,
                 supersample: int) -> np.ndarray:
    """The convex hulls of the shape's parts, their points (`shape.points_mm`) placed at `world_mm`, filled in `roi`
    on the grid of `silhouette`; empty where a point lies behind the camera."""
    canvas = np.zeros((roi.height_px * supersample, roi.width_px * supersample), np.uint8)
    pixels = camera.project(world_mm)
    if not np.all(np.isfinite(pixels)):
        return canvas > 0  # part of the vehicle behind the camera: no silhouette to compare
    scaled = np.round(((pixels - [roi.x0, roi.y0] + 0.5) * supersample - 0.5) * (1 << SUBPIXEL_SHIFT)).astype(np.int32)
    for part in np.split(scaled, shape.part_starts):
        cv2.fillConvexPoly(canvas, cv2.convexHull(part), 1, cv2.LINE_8, SUBPIXEL_SHIFT)
    return canvas.view(bool)


def coverage(camera: PinholeCamera, shape: VehicleShape, box: VehicleBox, roi: Box, supersample: int) -> np.ndarray:
    """How much of each pixel of `roi` the shape at `box` covers (float32 in [0, 1], in steps of 1 / supersample²)."""
    drawn = silhouette(camera, shape, box, roi, supersample).astype(np.float32)
    if supersample == 1:
        return drawn
    return cv2.resize(drawn, (roi.width_px, roi.height_px), interpolation=cv2.INTER_AREA)


def overlap(covered: np.ndarray, weights: np.ndarray) -> float:
    """How well a shape's pixel coverage matches the foreground's weights (both in [0, 1]): the sum of their
    pixel-wise minimum over that of their maximum (for a bool mask and bool weights, the intersection over union;
    for a fractional weight, best where the shape covers that share of the pixel)."""
    weights = np.asarray(weights, dtype=np.float32)
    union = float(np.maximum(covered, weights).sum())
    return float(np.minimum(covered, weights).sum()) / union if union else 0.0


def fit_model(
    camera: PinholeCamera,
    weights: np.ndarray,
    roi: Box,
    shape: VehicleShape,
    start: VehicleBox,
    params: FitParams | None = None,
    fit_heading: bool = True,
) -> ModelFit:
    """The pose of `shape` (length and width as `start`'s) that best overlaps the vehicle's foreground inside
    `roi`: `weights`, a (roi height, roi width) array in [0, 1] (a bool mask, or how sure each pixel is),
    starting from `start`; with `fit_heading` false only the position moves, the heading stays `start`'s
    (or its reverse)."""
    from scipy.optimize import minimize  # scipy on first use: a refused CLI answers sooner
    params = params or FitParams.from_config()
    ss = params.supersample_for(roi)
    target = np.asarray(weights, dtype=np.float32)

    # Nelder-Mead stops on one tolerance for all coordinates: the heading is scaled to make it the angular one
    per_deg = params.tolerance_mm / params.tolerance_deg

    def box_of(values: np.ndarray, heading_deg: float) -> VehicleBox:
        turned_deg = float(values[2] / per_deg) if fit_heading else heading_deg
        return VehicleBox(values[:2].copy(), turned_deg, start.length_mm, start.width_mm)

    def cost(values: np.ndarray, heading_deg: float) -> float:
        return 1.0 - overlap(coverage(camera, shape, box_of(values, heading_deg), roi, ss), target)

    headings = [start.heading_deg] + ([heading_difference_deg(start.heading_deg + 180.0, 0.0)] if params.try_reversed else [])
    coordinates = 3 if fit_heading else 2
    fits = []
    for heading_deg in headings:
        x0 = np.array([start.centre_mm[0], start.centre_mm[1], heading_deg * per_deg][:coordinates])
        steps = np.diag([params.start_step_mm, params.start_step_mm, params.start_step_deg * per_deg][:coordinates])
        result = minimize(
            cost, x0, args=(heading_deg,), method="Nelder-Mead",
            options={"initial_simplex": np.vstack([x0, x0 + steps]), "xatol": params.tolerance_mm,
                     "fatol": 1e-7, "maxfev": params.max_evaluations},
        )
        fits.append((1.0 - float(result.fun), box_of(result.x, heading_deg), int(result.nfev)))
    iou, box, _ = max(fits, key=lambda fit: fit[0])
    return ModelFit(box, iou, sum(fit[2] for fit in fits))


def best_start(camera: PinholeCamera, weights: np.ndarray, roi: Box, shape: VehicleShape,
               candidates: list[VehicleBox], supersample: int) -> VehicleBox:
    """Of the candidate starts, the one whose silhouette overlaps the foreground `weights` (as in `fit_model`)
    most: a coarse search before the fit, for a start far from the vehicle."""
    target = np.asarray(weights, dtype=np.float32)
    scores = [overlap(coverage(camera, shape, box, roi, supersample), target) for box in candidates]
    return candidates[int(np.argmax(scores))]
