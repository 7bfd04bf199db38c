"""The shadow beside a vehicle, told from the vehicle itself by how it darkens the road.

A pixel only darker than the road may be the vehicle's shadow or a dark part of the vehicle (a tyre, a window,
dark paint); the silhouette cannot tell them apart pixel by pixel and weighs them all the same. Around a fitted pose
the road's darkening is smooth, so a few numbers model it: the footprint on the road, grown and shifted away from the
light, soft-edged and uniformly dark (`RoadShadow`). It is fitted to the light ratio (frame over background) of the
pixels outside the vehicle's projected shape (`fit_road_shadow`), and the doubtful pixels whose ratio it explains are
the shadow; the others, whose light it does not explain, are the vehicle's (`shadow_pixels`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import FitParams, ModelFit, fit_model, silhouette
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.roi import Silhouette

RATIO_MEDIAN_PX = 5
"""The light ratio is taken through a median of this window: the sensor's noise moves one pixel's by about 0.04."""
RATIO_LEVELS = 100.0
"""The ratio's resolution in the median (it runs on 8-bit levels: ratios up to 2.55)."""
HUBER_RATIO = 0.06
"""Ratio residuals beyond this count linearly in the shadow's fit (a dark part of the vehicle outside its fitted
shape, or another vehicle's pixels, must not pull it)."""
CAR_MARGIN_PX = 2
"""The vehicle's projected shape grown by this before its pixels are left out of the shadow's fit."""
START_OFFSETS_MM = ((0.0, 0.0), (300.0, 0.0), (-300.0, 0.0), (0.0, 300.0), (0.0, -300.0))
"""Where the shadow's fit starts: under the vehicle and shifted each way along the road."""
START_GROWTH, START_STRENGTH, START_BLUR_FRACTION = 1.05, 0.5, 0.02
STEP_MM, STEP_GROWTH, STEP_STRENGTH, STEP_BLUR_FRACTION = 200.0, 0.05, 0.1, 0.01
MIN_GROWTH, MAX_STRENGTH, MIN_BLUR_PX = 0.5, 0.95, 0.3


@dataclass(frozen=True)
class RoadShadow:
    """A vehicle's shadow on the road: its footprint scaled by `growth` about its centre and shifted by `offset_mm`,
    taking `strength` of the road's light, its edge blurred by `blur_px` (a Gaussian's sigma, in ROI pixels)."""

    offset_mm: tuple[float, float]
    growth: float
    strength: float
    blur_px: float

    @classmethod
    def of(cls, values: np.ndarray, scale: float) -> RoadShadow:
        """From the fit's coordinates (blur in pixels of a grid `scale` times the ROI's), clipped to sense."""
        return cls((float(values[0]), float(values[1])), max(float(values[2]), MIN_GROWTH),
                   float(np.clip(values[3], 0.0, MAX_STRENGTH)), max(abs(float(values[4])), MIN_BLUR_PX) / scale)


def light_ratio_smoothed(light_ratio: np.ndarray) -> np.ndarray:
    """The silhouette's light ratio (frame over background) through a `RATIO_MEDIAN_PX` median."""
    levels = np.clip(np.round(light_ratio * RATIO_LEVELS), 0, 255).astype(np.uint8)
    return cv2.medianBlur(levels, RATIO_MEDIAN_PX).astype(np.float32) / RATIO_LEVELS


def darkening(camera: PinholeCamera, box: VehicleBox, roi: Box, shadow: RoadShadow, scale: float = 1.0) -> np.ndarray:
    """The share of the road's light `shadow` of the footprint `box` takes off over `roi` (float32), on a grid
    `scale` times the ROI's."""
    height_px, width_px = max(1, round(roi.height_px * scale)), max(1, round(roi.width_px * scale))
    canvas = np.zeros((height_px, width_px), np.float32)
    centre = np.asarray(box.centre_mm, float)
    corners = centre + (box.corners_mm() - centre) * shadow.growth + np.asarray(shadow.offset_mm)
    polygon_px = camera.project_polygon(np.column_stack([corners, np.zeros(len(corners))]))
    if len(polygon_px) < 3:
        return canvas
    points = np.round(((polygon_px - [roi.x0, roi.y0] + 0.5) * scale - 0.5) * 16).astype(np.int32)
    cv2.fillConvexPoly(canvas, points, 1.0, cv2.LINE_AA, 4)
    return shadow.strength * cv2.GaussianBlur(canvas, (0, 0), max(shadow.blur_px * scale, MIN_BLUR_PX))


def fit_road_shadow(camera: PinholeCamera, shape: VehicleShape, box: VehicleBox, roi: Box, ratio: np.ndarray,
                    grid_px: int, max_evaluations: int) -> RoadShadow:
    """The `RoadShadow` of the vehicle fitted at `box` that best explains the smoothed light `ratio` of the ROI's
    pixels outside the vehicle's projected shape (a Huber loss on ratio residuals), on a grid whose longer side is at
    most `grid_px`: Nelder-Mead from each of `START_OFFSETS_MM`, at most `max_evaluations` each."""
    from scipy.optimize import minimize  # scipy on first use, as the model fit
    scale = min(1.0, grid_px / max(roi.width_px, roi.height_px))
    size = (max(1, round(roi.width_px * scale)), max(1, round(roi.height_px * scale)))
    car = silhouette(camera, shape, box, roi, 1).view(np.uint8)
    grown = cv2.dilate(car, np.ones((2 * CAR_MARGIN_PX + 1,) * 2, np.uint8))
    outside = cv2.resize(grown, size, interpolation=cv2.INTER_NEAREST) == 0
    observed = cv2.resize(ratio, size, interpolation=cv2.INTER_AREA)[outside]
    extent_px = max(size)

    def cost(values: np.ndarray) -> float:
        residual = observed - (1.0 - darkening(camera, box, roi, RoadShadow.of(values, scale), scale)[outside])
        magnitude = np.abs(residual)
        return float(np.where(magnitude < HUBER_RATIO, 0.5 * residual**2,
                              HUBER_RATIO * (magnitude - 0.5 * HUBER_RATIO)).sum())

    steps = np.diag([STEP_MM, STEP_MM, STEP_GROWTH, STEP_STRENGTH, STEP_BLUR_FRACTION * extent_px])
    best = None
    for dx_mm, dy_mm in START_OFFSETS_MM:
        x0 = np.array([dx_mm, dy_mm, START_GROWTH, START_STRENGTH, START_BLUR_FRACTION * extent_px])
        result = minimize(cost, x0, method="Nelder-Mead",
                          options={"initial_simplex": np.vstack([x0, x0 + steps]), "maxfev": max_evaluations,
                                   "xatol": 1.0, "fatol": 1e-4})
        if best is None or result.fun < best.fun:
            best = result
    return RoadShadow.of(best.x, scale)


def shadow_pixels(ratio: np.ndarray, shadow_darkening: np.ndarray, tolerance: float,
                  min_darkening: float) -> np.ndarray:
    """Where the smoothed light `ratio` is that of the fitted shadow (within `tolerance` of one minus its
    `shadow_darkening`) and the shadow darkens the road by at least `min_darkening`."""
    return (np.abs(ratio - (1.0 - shadow_darkening)) < tolerance) & (shadow_darkening >= min_darkening)


def refit_without_shadow(camera: PinholeCamera, silhouette: Silhouette, roi: Box, shape: VehicleShape, fit: ModelFit,
                         params: FitParams) -> tuple[ModelFit, np.ndarray]:
    """`params.shadow_passes` times: the road's shadow fitted around `fit`'s pose, the silhouette's doubtful pixels
    it explains taken out of the fit's weights (the outline's shares in place: `Silhouette.weights_at_edges`), and the
    vehicle refitted from that pose (facing as it does); the last fit and the weights it was fitted to."""
    ratio = light_ratio_smoothed(silhouette.light_ratio)
    weights = shared = silhouette.weights_at_edges()
    refit_params = replace(params, try_reversed=False)
    for _ in range(params.shadow_passes):
        shadow = fit_road_shadow(camera, shape, fit.box, roi, ratio, params.shadow_grid_px,
                                 params.shadow_max_evaluations)
        shadowed = shadow_pixels(ratio, darkening(camera, fit.box, roi, shadow), params.shadow_ratio_tolerance,
                                 params.shadow_min_darkening)
        weights = np.where(silhouette.doubtful & shadowed, 0.0, shared)
        refit = fit_model(camera, weights, roi, shape, fit.box, refit_params)
        fit = replace(refit, evaluations=fit.evaluations + refit.evaluations)
    return fit, weights
