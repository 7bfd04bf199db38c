"""The shadow beside a vehicle, told from the vehicle itself by how it darkens the road.

A pixel only darker than the road may be the vehicle's shadow or a dark part of the vehicle (a tyre, a window,
dark paint); the silhouette cannot tell them apart pixel by pixel and weighs them all the same. Around a fitted pose
the road's darkening is smooth, so a few numbers model it: the footprint on the road, grown and shifted away from the
light, soft-edged and uniformly dark (`RoadShadow`). It is fitted to the light ratio (frame over background) of the
pixels outside the vehicle's projected shape (`fit_road_shadow`), and the doubtful pixels whose ratio it explains are
the shadow; the others, whose light it does not explain, are the vehicle's (`shadow_pixels`). A grey vehicle on a grey
road can be refitted to a pose off along the line of sight that overlaps its weights as well; its fitted shadow then
leaves the doubtful pixels outside it unexplained (`unexplained_outside`), and the refit is started again from either
side (`refit_with_restarts`). Where the vehicle meets its shadow, an outline pixel's light mixes the vehicle's and
the shadowed road's in proportion to the share of it each covers, which it gives back (`shadow_edge_shares`); a pixel
there outside the silhouette whose light is the vehicle's beside it, and that no mix can read, may be its face in shade
or its shadow (`undecided_edge`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.edge_coverage import MIX_SLACK, band_and_inner
from vehloc.geometry.model_fit import FitParams, ModelFit, coverage, fit_model, silhouette
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.roi import Silhouette

RATIO_MEDIAN_PX = 5
"""The light ratio is taken through a median of this window: the sensor's noise moves one pixel's by about 0.04."""
RATIO_LEVELS = 100.0
"""The ratio's resolution in the median (it runs on 8-bit levels: ratios up to 2.55)."""
HUBER_RATIO = 0.06
"""Ratio residuals beyond this count linearly in the shadow's fit (a dark part of the vehicle outside its fitted
shape, or another vehicle's pixels, must not pull it)."""
START_OFFSETS_MM = ((0.0, 0.0), (300.0, 0.0), (-300.0, 0.0), (0.0, 300.0), (0.0, -300.0))
"""Where the shadow's fit starts: under the vehicle and shifted each way along the road."""
RESTART_MAX_SHARE = 0.5
"""A restarted refit is kept where it leaves at most this share of the first answer's unexplained doubtful pixels ..."""
RESTART_MIN_PX = 30
"""... and at least this many fewer (a few pixels more or less are noise, not another fixed point)."""
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


class ShadowDrawer:
    """Draws the darkening of `RoadShadow`s of one footprint over one ROI on a grid `scale` times the ROI's; what
    does not change from one shadow to the next (the footprint's corners about its centre, the grid) is set once."""

    def __init__(self, camera: PinholeCamera, box: VehicleBox, roi: Box, scale: float = 1.0):
        self.camera, self.roi, self.scale = camera, roi, scale
        self.size_px = (max(1, round(roi.height_px * scale)), max(1, round(roi.width_px * scale)))
        self.centre_mm = np.asarray(box.centre_mm, float)
        self.about_centre_mm = box.corners_mm() - self.centre_mm

    def __call__(self, shadow: RoadShadow) -> np.ndarray:
        """The share of the road's light `shadow` takes off over the grid (float32)."""
        canvas = np.zeros(self.size_px, np.float32)
        corners = self.centre_mm + self.about_centre_mm * shadow.growth + np.asarray(shadow.offset_mm)
        polygon_px = self.camera.project_polygon(np.column_stack([corners, np.zeros(len(corners))]))
        if len(polygon_px) < 3:
            return canvas
        points = np.round(((polygon_px - [self.roi.x0, self.roi.y0] + 0.5) * self.scale - 0.5) * 16).astype(np.int32)
        cv2.fillConvexPoly(canvas, points, 1.0, cv2.LINE_AA, 4)
        return shadow.strength * cv2.GaussianBlur(canvas, (0, 0), max(shadow.blur_px * self.scale, MIN_BLUR_PX))


def darkening(camera: PinholeCamera, box: VehicleBox, roi: Box, shadow: RoadShadow, scale: float = 1.0) -> np.ndarray:
    """The share of the road's light `shadow` of the footprint `box` takes off over `roi` (float32), on a grid
    `scale` times the ROI's."""
    return ShadowDrawer(camera, box, roi, scale)(shadow)


def fit_road_shadow(camera: PinholeCamera, shape: VehicleShape, box: VehicleBox, roi: Box, ratio: np.ndarray,
                    grid_px: int, max_evaluations: int, car_margin_px: int) -> RoadShadow:
    """The `RoadShadow` of the vehicle fitted at `box` that best explains the smoothed light `ratio` of the ROI's
    pixels outside the vehicle's projected shape grown by `car_margin_px` (a Huber loss on ratio residuals), on a grid
    whose longer side is at most `grid_px`: Nelder-Mead from each of `START_OFFSETS_MM`, at most `max_evaluations`
    each."""
    from scipy.optimize import minimize  # scipy on first use, as the model fit
    scale = min(1.0, grid_px / max(roi.width_px, roi.height_px))
    size = (max(1, round(roi.width_px * scale)), max(1, round(roi.height_px * scale)))
    car = silhouette(camera, shape, box, roi, 1).view(np.uint8)
    grown = cv2.dilate(car, np.ones((2 * car_margin_px + 1,) * 2, np.uint8))
    outside = cv2.resize(grown, size, interpolation=cv2.INTER_NEAREST) == 0
    observed = cv2.resize(ratio, size, interpolation=cv2.INTER_AREA)[outside]
    extent_px = max(size)
    draw = ShadowDrawer(camera, box, roi, scale)

    def cost(values: np.ndarray) -> float:
        residual = observed - (1.0 - draw(RoadShadow.of(values, scale))[outside])
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


def shadow_edge_shares(light_ratio: np.ndarray, shaded: np.ndarray, fitted: np.ndarray, lit: np.ndarray,
                       band_px: int, min_difference: float) -> np.ndarray:
    """Where a vehicle meets its shadow: the share of each `shaded` pixel (in the shadow, or maybe) within `band_px`
    of the outline of `fitted` (the fitted shape's pixels; inside and out) the vehicle covers, read from its
    `light_ratio` as a mix of the vehicle's (the nearest pixel deeper inside, as `edge_coverage`) and the shadowed
    road's (`lit`: one minus the shadow's darkening), where the two differ by more than `min_difference` and the mix
    is within `MIX_SLACK` of [0, 1]; NaN elsewhere (float32)."""
    share = np.full(light_ratio.shape, np.nan, np.float32)
    pairs = band_and_inner(fitted, band_px)
    if pairs is None:
        return share
    band_rows, band_cols, inner_row, inner_col = pairs
    read = shaded[band_rows, band_cols]
    band_rows, band_cols, inner_row, inner_col = band_rows[read], band_cols[read], inner_row[read], inner_col[read]
    road = lit[band_rows, band_cols]
    difference = light_ratio[inner_row, inner_col] - road
    mixed = (light_ratio[band_rows, band_cols] - road) / np.where(difference == 0.0, 1.0, difference)
    readable = (np.abs(difference) > min_difference) & (mixed > -MIX_SLACK) & (mixed < 1.0 + MIX_SLACK)
    share[band_rows[readable], band_cols[readable]] = np.clip(mixed[readable], 0.0, 1.0)
    return share


def undecided_edge(light_ratio: np.ndarray, outside: np.ndarray, fitted: np.ndarray, band_px: int,
                   max_difference: float, min_darkening: float) -> np.ndarray:
    """The pixels within `band_px` of the outline of `fitted` (the fitted shape's pixels; inside and out) that are
    `outside` the silhouette, darker than the road by at least `min_darkening` (`light_ratio`), and whose light ratio
    is within `max_difference` of the vehicle's beside them (the nearest pixel deeper inside, as `edge_coverage`):
    the vehicle's face in shade or its shadow, which neither the silhouette nor a light mix tells apart (bool)."""
    undecided = np.zeros(light_ratio.shape, bool)
    pairs = band_and_inner(fitted, band_px)
    if pairs is None:
        return undecided
    band_rows, band_cols, inner_row, inner_col = pairs
    ratio = light_ratio[band_rows, band_cols]
    alike = ((ratio <= 1.0 - min_darkening) & outside[band_rows, band_cols]
             & (np.abs(ratio - light_ratio[inner_row, inner_col]) < max_difference))
    undecided[band_rows[alike], band_cols[alike]] = True
    return undecided


def refit_without_shadow(camera: PinholeCamera, silhouette: Silhouette, roi: Box, shape: VehicleShape, fit: ModelFit,
                         params: FitParams) -> tuple[ModelFit, np.ndarray]:
    """`params.shadow_passes` times: the road's shadow fitted around `fit`'s pose, the silhouette's doubtful pixels
    it explains taken out of the fit's weights (the outline's shares in place: `Silhouette.weights_at_edges`), those
    near the fitted outline, and the pixels there that the shadow darkens (by `params.shadow_min_darkening` or more:
    their colour's share, read against the unshadowed road, does not hold), weighing the share of them the vehicle
    covers against the shadowed road (`shadow_edge_shares`, with `params.shadow_edge_band_px`), those there outside the
    silhouette whose share is not so read and whose light is the vehicle's beside them weighing
    `params.shadow_edge_undecided_weight` (`undecided_edge`), and the vehicle refitted from that pose (facing as it
    does); the last fit and the weights it was fitted to."""
    ratio = light_ratio_smoothed(silhouette.light_ratio)
    weights = shared = silhouette.weights_at_edges()
    refit_params = replace(params, try_reversed=False)
    for _ in range(params.shadow_passes):
        shadow = fit_road_shadow(camera, shape, fit.box, roi, ratio, params.shadow_grid_px,
                                 params.shadow_max_evaluations, params.shadow_car_margin_px)
        shade = darkening(camera, fit.box, roi, shadow)
        shadowed = shadow_pixels(ratio, shade, params.shadow_ratio_tolerance, params.shadow_min_darkening)
        weights = np.where(silhouette.doubtful & shadowed, 0.0, shared)
        if params.shadow_edge_band_px:
            fitted = coverage(camera, shape, fit.box, roi, 1) >= 0.5
            shaded = silhouette.doubtful | (shade >= params.shadow_min_darkening)
            edge = shadow_edge_shares(silhouette.light_ratio, shaded, fitted, 1.0 - shade,
                                      params.shadow_edge_band_px, params.shadow_edge_min_difference)
            weights = np.where(np.isnan(edge), weights, edge)
            undecided = np.isnan(edge) & undecided_edge(silhouette.light_ratio, ~silhouette.mask, fitted,
                                                        params.shadow_edge_band_px, params.shadow_edge_min_difference,
                                                        params.shadow_min_darkening)
            weights = np.where(undecided, params.shadow_edge_undecided_weight, weights)
        refit = fit_model(camera, weights, roi, shape, fit.box, refit_params)
        fit = replace(refit, evaluations=fit.evaluations + refit.evaluations)
    return fit, weights


def unexplained_outside(camera: PinholeCamera, silhouette: Silhouette, roi: Box, shape: VehicleShape, box: VehicleBox,
                        ratio: np.ndarray, params: FitParams) -> tuple[int, int]:
    """The silhouette's doubtful pixels outside the shape at `box`, and how many of them the road's shadow fitted
    around `box` leaves unexplained (their smoothed light `ratio` more than `params.shadow_ratio_tolerance` from its)."""
    shadow = fit_road_shadow(camera, shape, box, roi, ratio, params.shadow_grid_px, params.shadow_max_evaluations,
                             params.shadow_car_margin_px)
    lit = 1.0 - darkening(camera, box, roi, shadow)
    outside = silhouette.doubtful & (coverage(camera, shape, box, roi, 1) < 0.5)
    return int(outside.sum()), int((outside & (np.abs(ratio - lit) >= params.shadow_ratio_tolerance)).sum())


def refit_with_restarts(camera: PinholeCamera, silhouette: Silhouette, roi: Box, shape: VehicleShape, fit: ModelFit,
                        params: FitParams) -> tuple[ModelFit, np.ndarray]:
    """`refit_without_shadow` from `fit`; where the shadow fitted around its answer explains less than
    `params.shadow_restart_below` of the doubtful pixels outside the vehicle, also from `fit` moved
    `params.shadow_restart_mm` each way along the line of sight, a restart's answer kept where it leaves at most
    `RESTART_MAX_SHARE` of the first's unexplained pixels and `RESTART_MIN_PX` fewer (the fewest of the restarts);
    the kept fit (with every refit's evaluations) and the weights it was fitted to."""
    refit, weights = refit_without_shadow(camera, silhouette, roi, shape, fit, params)
    if params.shadow_restart_mm <= 0 or params.shadow_passes == 0:
        return refit, weights
    ratio = light_ratio_smoothed(silhouette.light_ratio)
    outside, unexplained = unexplained_outside(camera, silhouette, roi, shape, refit.box, ratio, params)
    if outside == 0 or outside - unexplained >= params.shadow_restart_below * outside:
        return refit, weights
    sight = fit.box.centre_mm - camera.centre_mm[:2]
    if not np.linalg.norm(sight) > 0:  # under the camera: no line of sight along the road
        return refit, weights
    sight = sight / np.linalg.norm(sight)
    kept, evaluations, fewest = (refit, weights), refit.evaluations, unexplained
    for sign in (-1.0, 1.0):
        start = replace(fit, box=replace(fit.box, centre_mm=fit.box.centre_mm + sign * params.shadow_restart_mm * sight))
        again, again_weights = refit_without_shadow(camera, silhouette, roi, shape, start, params)
        evaluations += again.evaluations - fit.evaluations
        left = unexplained_outside(camera, silhouette, roi, shape, again.box, ratio, params)[1]
        if left <= RESTART_MAX_SHARE * unexplained and unexplained - left >= RESTART_MIN_PX and left < fewest:
            kept, fewest = (again, again_weights), left
    return replace(kept[0], evaluations=evaluations), kept[1]
