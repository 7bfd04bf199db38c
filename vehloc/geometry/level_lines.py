"""Level lines across a vehicle's end (a plate's edges, the line through its lamps, its lower outline): their road
direction, and the end's lower outline below a small licence plate read as one.

The inverse road homography keeps a level 3D line's direction, whatever its height (it scales the line about the
camera's foot), so an image line of a level edge gives its direction on the road (`level_lines_direction_deg`).
A small plate's sides are its colour's outline, along the image's pixel rows, so its edges give the direction across
the vehicle only to a pixel over the plate's width, several degrees on the road for a far car. The end's lower
outline below the plate (the bumper's bottom edge, the silhouette's lowest pixels with the shadow under the vehicle
trimmed away) is level and across the vehicle too, over a baseline a few times the plate's width: a line fitted to
it gives that direction more closely, where the outline is a line (a quarter view's side or a wheel bends it). The
line's slope carries its standard error (the outline's scatter about it, never below a whole pixel row's
quantization; and a digital line is pinned only where it changes rows: an outline that changes rows k times over a
span is known no better than a pixel over a (k + 1)th of it, uniformly), turned into degrees on the road; it is used where that is small and where the line's slope in the
image is the plate's within a pixel over the plate's width (what the plate itself tells).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.config import check_range
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.silhouette_start import lower_outline_px

ROW_QUANTIZATION_PX = 1.0 / np.sqrt(12.0)
"""The standard deviation of a whole-pixel row about the edge it samples: the least scatter an outline has."""
MAD_FLOOR_PX = 0.3
"""Added to the outline's median absolute residual before outliers are cut (a straight outline has a MAD of 0)."""
TRIM_ROUNDS = 3


@dataclass(frozen=True)
class EndLineParams:
    """Where the end's lower outline is read and when its line is trusted (`plate.end_line` of
    `conf/localize/plate/`)."""

    enabled: bool
    half_span_plate_widths: float
    trim_deviations: float
    max_sigma_deg: float
    plate_agreement_px: float

    def __post_init__(self) -> None:
        check_range("half_span_plate_widths", self.half_span_plate_widths, 0.0, low_open=True)
        check_range("trim_deviations", self.trim_deviations, 0.0, low_open=True)
        check_range("max_sigma_deg", self.max_sigma_deg, 0.0, 90.0, low_open=True)
        check_range("plate_agreement_px", self.plate_agreement_px, 0.0)


@dataclass(frozen=True)
class EndLine:
    """The end's lower outline as a line: its image slope (dy/dx), the road direction (deg, [0, 180)) of the level
    line it is, that direction's 1-sigma (deg) and the outline points it was fitted to (frame px)."""

    slope: float
    across_deg: float
    sigma_deg: float
    points_px: np.ndarray


def robust_line(points_px: np.ndarray, trim_deviations: float) -> tuple[float, float, np.ndarray]:
    """y = intercept + slope x through `points_px` (N, 2), refitted `TRIM_ROUNDS` times without the points further
    than `trim_deviations` times (the median absolute residual + `MAD_FLOOR_PX`) from it: (slope, intercept, kept)."""
    x, y = points_px[:, 0], points_px[:, 1]
    kept = np.ones(len(x), bool)
    slope, intercept = np.polyfit(x, y, 1)
    for _ in range(TRIM_ROUNDS):
        residual = y - (intercept + slope * x)
        kept = np.abs(residual) <= trim_deviations * (np.median(np.abs(residual[kept])) + MAD_FLOOR_PX)
        if kept.sum() < 3:
            break
        slope, intercept = np.polyfit(x[kept], y[kept], 1)
    return float(slope), float(intercept), kept


def level_lines_direction_deg(lines_px: np.ndarray, road_to_image: ProjectiveTransform) -> float:
    """The road direction (deg, [0, 180)) of level 3D lines seen as the image lines `lines_px` (n, 3), their mean:
    each maps by the inverse homography to a road line of its own direction."""
    road_lines = road_to_image.inverse.map_lines(np.atleast_2d(lines_px))
    doubled = 2.0 * np.arctan2(-road_lines[:, 0], road_lines[:, 1])
    return float(np.degrees(np.angle(np.exp(1j * doubled).sum())) / 2.0 % 180.0)


def level_line_direction_deg(slope: float, through_px: np.ndarray, road_to_image: ProjectiveTransform) -> float:
    """The road direction (deg, [0, 180)) of a level 3D line whose image passes through `through_px` with `slope`."""
    line = np.cross([*through_px, 1.0], [through_px[0] + 1.0, through_px[1] + slope, 1.0])
    return level_lines_direction_deg(line[None], road_to_image)


def end_line(mask: np.ndarray, offset_px: np.ndarray, centre_px: np.ndarray, width_px: float,
             road_to_image: ProjectiveTransform, params: EndLineParams) -> EndLine | None:
    """The lower outline of the silhouette `mask` (the ROI's, at `offset_px`; its shadow trimmed) over the columns
    within `half_span_plate_widths` plate widths (`width_px`) of the plate's middle `centre_px`, as a line; None with
    fewer than three outline points left after the outliers are cut."""
    outline = lower_outline_px(mask, offset_px)
    outline = outline[np.abs(outline[:, 0] - centre_px[0]) <= params.half_span_plate_widths * width_px]
    if len(outline) < 3:
        return None
    slope, intercept, kept = robust_line(outline, params.trim_deviations)
    points = outline[kept]
    if len(points) < 3:
        return None
    x = points[:, 0]
    scatter_px = max(float(np.sqrt(np.mean((points[:, 1] - intercept - slope * x) ** 2))), ROW_QUANTIZATION_PX)
    row_changes = int(np.count_nonzero(np.diff(points[np.argsort(x), 1])))
    slope_sigma = max(scatter_px / float(np.sqrt(np.sum((x - x.mean()) ** 2))),
                      1.0 / (np.sqrt(3.0) * float(np.ptp(x)) * (1 + row_changes)))
    middle = np.array([x.mean(), intercept + slope * x.mean()])
    across = level_line_direction_deg(slope, middle, road_to_image)
    sigma = max(abs((level_line_direction_deg(slope + sign * slope_sigma, middle, road_to_image) - across + 90.0)
                    % 180.0 - 90.0) for sign in (-1.0, 1.0))
    return EndLine(slope, across, sigma, points)


def end_line_heading_deg(mask: np.ndarray, offset_px: np.ndarray, corners_px: np.ndarray, centre_px: np.ndarray,
                         road_to_image: ProjectiveTransform, params: EndLineParams) -> float | None:
    """The length axis (deg, [0, 180)) perpendicular to the end's lower outline below a small plate (`corners_px`,
    ordered; its middle `centre_px`), where the outline's line is known within `max_sigma_deg` on the road and its
    image slope lies within `plate_agreement_px` over the plate's width of the plate's own; None otherwise, or
    when off."""
    if not params.enabled:
        return None
    width_px = float(np.linalg.norm(corners_px[1] - corners_px[0]) + np.linalg.norm(corners_px[2] - corners_px[3])) / 2
    line = end_line(mask, offset_px, centre_px, width_px, road_to_image, params)
    if line is None or line.sigma_deg > params.max_sigma_deg:
        return None
    along = (corners_px[1] - corners_px[0]) + (corners_px[2] - corners_px[3])
    plate_deg = np.degrees(np.arctan2(along[1], along[0]))
    gap_deg = abs((np.degrees(np.arctan(line.slope)) - plate_deg + 90.0) % 180.0 - 90.0)
    if gap_deg > np.degrees(np.arctan2(params.plate_agreement_px, width_px)):
        return None
    return (line.across_deg + 90.0) % 180.0
