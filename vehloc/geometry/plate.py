"""Licence plate in a vehicle ROI (paper, Sec. II-E): colour, then edges; its quadrilateral, its upper and lower
lines l_UL and l_LL, and its middle point P.

The plate's background colour is a rule in HSV (light plates with dark characters by default: low saturation,
and lighter than their surroundings, a white top-hat with a kernel a few times the plate's light strokes;
blue Chinese plates by another hue, saturation and value range with the top-hat off). A closing along the rows
joins the plate's colour across the characters and holes are filled. Each such blob is then taken again at
its own level: plate-coloured pixels at least half-way from the darkest value around it to its own light,
which parts the plate from a body of middle tone touching it across the plate's dark border. A blob is a plate when its
quadrilateral has a plate's aspect, the blob fills it, and a row through its middle crosses the characters.
Each side of the quadrilateral is then placed on the image edges, where the intensity crosses half-way between
the plate's colour and its surroundings, interpolated between pixels; P is where the diagonals meet (the
image of the plate's centre, whatever the perspective).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import map_coordinates

from vehloc.config import params_from_config
from vehloc.geometry.markers import quadrilateral_of_blob


@dataclass(frozen=True)
class PlateParams:
    """Colour rule (OpenCV's 8-bit HSV: H 0-180, S and V 0-255), blob tests and edge refinement."""

    hue_range: tuple[int, int]
    saturation_range: tuple[int, int]
    value_range: tuple[int, int]
    min_contrast: float
    tophat_fraction: float
    close_px: tuple[int, int]
    min_width_px: float
    max_width_fraction: float
    aspect_range: tuple[float, float]
    min_fill: float
    character_fraction_range: tuple[float, float]
    min_crossings: int
    expected_crossings: int
    edge_reach_fraction: float
    min_fitted_side_px: float
    min_score: float

    @classmethod
    def from_config(cls, **overrides: object) -> PlateParams:
        """The settings of `conf/plate/default.yaml`, with `overrides`."""
        return params_from_config(cls, "plate/default.yaml", overrides)


@dataclass(frozen=True, eq=False)
class Plate:
    """A detected licence plate in frame px.

    ``corners_px`` (4, 2): top-left, top-right, bottom-right, bottom-left as seen in the image;
    ``centre_px``: P, where the diagonals meet; ``upper_line_px`` and ``lower_line_px``: l_UL and l_LL,
    homogeneous `a x + b y + c = 0` with `a^2 + b^2 = 1` and the plate on the positive side;
    ``score`` in [0, 1]: how much the blob fills its quadrilateral times how clearly its middle row crosses
    the characters."""

    corners_px: np.ndarray
    centre_px: np.ndarray
    upper_line_px: np.ndarray
    lower_line_px: np.ndarray
    score: float


def plate_colour_masks(roi_bgr: np.ndarray, params: PlateParams) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (bool) of the plate's background colour by the HSV ranges, and those of them that also stand out
    from their surroundings by the white top-hat (all of them with the top-hat off)."""
    hue, saturation, value = cv2.split(cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2HSV))
    colour = np.ones(hue.shape, bool)
    for channel, (low, high) in ((hue, params.hue_range), (saturation, params.saturation_range),
                                 (value, params.value_range)):
        colour &= (channel >= low) & (channel <= high)
    if params.min_contrast <= 0:
        return colour, colour
    size = max(3, int(round(params.tophat_fraction * roi_bgr.shape[1])) | 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (size, size))
    return colour, colour & (cv2.morphologyEx(value, cv2.MORPH_TOPHAT, kernel) >= params.min_contrast)


def filled_blobs(mask: np.ndarray, close_px: tuple[int, int]) -> list[np.ndarray]:
    """The blobs (bool masks) of a mask after a closing of `close_px` (width, height), their holes filled."""
    closed = cv2.morphologyEx(mask.astype(np.uint8), cv2.MORPH_CLOSE, np.ones(close_px[::-1], np.uint8))
    contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    blobs = []
    for contour in contours:
        blob = np.zeros_like(closed)
        cv2.drawContours(blob, [contour], -1, 1, cv2.FILLED)
        blobs.append(blob.astype(bool))
    return blobs


def order_corners(quad_px: np.ndarray) -> np.ndarray:
    """Four corners ordered top-left, top-right, bottom-right, bottom-left on screen (the plate's long sides
    are its top and bottom)."""
    centre = quad_px.mean(axis=0)
    quad = quad_px[np.argsort(np.arctan2(quad_px[:, 1] - centre[1], quad_px[:, 0] - centre[0]))]  # clockwise
    sides = np.linalg.norm(np.roll(quad, -1, axis=0) - quad, axis=1)
    if sides[0] + sides[2] < sides[1] + sides[3]:
        quad = np.roll(quad, -1, axis=0)  # make sides 0 and 2 the long ones
    top_first = quad[0, 1] + quad[1, 1] <= quad[2, 1] + quad[3, 1]
    return quad if top_first else np.roll(quad, 2, axis=0)


def middle_row_crossings(grey: np.ndarray, corners_px: np.ndarray) -> int:
    """How often a row through the middle of the quadrilateral, from its left to its right side, crosses its own
    mean intensity: twice per character."""
    left, right = (corners_px[0] + corners_px[3]) / 2, (corners_px[1] + corners_px[2]) / 2
    samples = max(8, int(np.ceil(4 * np.linalg.norm(right - left))))
    points = left + np.linspace(0.1, 0.9, samples)[:, None] * (right - left)
    profile = map_coordinates(grey, [points[:, 1], points[:, 0]], order=1, mode="nearest")
    above = profile > profile.mean()
    return int(np.count_nonzero(above[1:] != above[:-1]))


def plate_shape(blob: np.ndarray, colour: np.ndarray, grey: np.ndarray, params: PlateParams, roi_width_px: int
                ) -> tuple[np.ndarray, float] | None:
    """The blob's quadrilateral (corners ordered) and its plate score, or None when it is not plate-like."""
    quad = quadrilateral_of_blob(blob.astype(np.uint8))
    if quad is None:
        return None
    corners = order_corners(quad)
    width_px = (np.linalg.norm(corners[1] - corners[0]) + np.linalg.norm(corners[2] - corners[3])) / 2
    height_px = (np.linalg.norm(corners[3] - corners[0]) + np.linalg.norm(corners[2] - corners[1])) / 2
    if not params.min_width_px <= width_px <= params.max_width_fraction * roi_width_px:
        return None
    if not params.aspect_range[0] <= width_px / max(height_px, 1e-9) <= params.aspect_range[1]:
        return None
    fill = np.count_nonzero(blob) / max(cv2.contourArea(corners.astype(np.float32)), 1.0)
    characters = 1.0 - colour[blob].mean()
    crossings = middle_row_crossings(grey, corners)
    low, high = params.character_fraction_range
    if fill < params.min_fill or not low <= characters <= high or crossings < params.min_crossings:
        return None
    return corners, float(min(fill, 1.0) * min(1.0, crossings / params.expected_crossings))


def character_core(blob: np.ndarray, colour: np.ndarray) -> np.ndarray | None:
    """Corners (ordered) of the rotated rectangle around the blob's characters (its pixels not of the plate's
    colour, in parts at least half as tall as the tallest, which leaves out slivers of border), or None."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats((blob & ~colour).astype(np.uint8), connectivity=8)
    if count < 2:
        return None
    heights = stats[1:, cv2.CC_STAT_HEIGHT]
    keep = 1 + np.flatnonzero(heights >= heights.max() / 2)
    rows, cols = np.nonzero(np.isin(labels, keep))
    squares = (np.column_stack([cols, rows])[:, None, :] + [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    return order_corners(cv2.boxPoints(cv2.minAreaRect(squares.reshape(-1, 2).astype(np.float32))).astype(float))


def edge_outwards(
    grey: np.ndarray, start_px: np.ndarray, end_px: np.ndarray, level: float, plate_above: bool, reach_px: float,
    min_fitted_px: float,
) -> np.ndarray | None:
    """The line (homogeneous) through the points where profiles leaving one side of the character core outwards
    first leave the plate's colour (the intensity passes `level` away from the plate's side after being on it),
    interpolated between samples: fitted to them on a side of `min_fitted_px` or more, else parallel to the side
    at their median offset; None when no profile leaves the plate."""
    direction = (end_px - start_px) / np.linalg.norm(end_px - start_px)
    outward = np.array([direction[1], -direction[0]])  # corners clockwise on screen: the right-hand normal points out
    samples = max(3, int(np.linalg.norm(end_px - start_px)))
    centres = start_px + np.linspace(0.1, 0.9, samples)[:, None] * (end_px - start_px)
    offsets = np.arange(-1.0, reach_px + 0.125, 0.25)
    points = centres[:, None, :] + offsets[None, :, None] * outward
    profiles = map_coordinates(grey, [points[..., 1], points[..., 0]], order=1, mode="nearest") - level
    found = []
    for centre, profile in zip(centres, profiles if plate_above else -profiles):
        leaving = np.flatnonzero((profile[:-1] >= 0) & (profile[1:] < 0))
        if len(leaving) == 0:
            continue
        i = leaving[0]
        found.append((centre, offsets[i] + profile[i] / (profile[i] - profile[i + 1]) * (offsets[i + 1] - offsets[i])))
    if not found:
        return None
    if np.linalg.norm(end_px - start_px) < min_fitted_px or len(found) < 3:
        through = start_px + float(np.median([offset for _, offset in found])) * outward
        return np.array([outward[0], outward[1], -outward @ through])
    points = np.array([centre + offset * outward for centre, offset in found])
    mean = points.mean(axis=0)
    normal = np.linalg.svd(points - mean)[2][1]
    return np.array([normal[0], normal[1], -normal @ mean])


def plate_corners(
    grey: np.ndarray, blob: np.ndarray, colour: np.ndarray, rough_px: np.ndarray, reach_fraction: float,
    min_fitted_px: float,
) -> np.ndarray:
    """The plate's corners from its edges found outwards from the characters; a side not found keeps the blob's,
    and corners that stray from the blob's by more than the plate's height fall back to the blob's."""
    core = character_core(blob, colour)
    plate_level, characters_level = np.median(grey[blob & colour]), np.median(grey[blob & ~colour])
    if core is None or plate_level == characters_level:
        return rough_px
    reach_px = reach_fraction * np.linalg.norm(core[3] - core[0])
    level = (plate_level + characters_level) / 2
    lines = []
    for k in range(4):
        line = edge_outwards(grey, core[k], core[(k + 1) % 4], level, plate_level > characters_level,
                             reach_px if k % 2 == 0 else 2 * reach_px, min_fitted_px)
        lines.append(line if line is not None else np.cross([*rough_px[k], 1.0], [*rough_px[(k + 1) % 4], 1.0]))
    corners = np.array([np.cross(lines[k - 1], lines[k]) for k in range(4)])
    if np.any(np.abs(corners[:, 2]) < 1e-12):
        return rough_px
    corners = corners[:, :2] / corners[:, 2:]
    stray_px = np.linalg.norm(rough_px[3] - rough_px[0])
    return corners if np.max(np.linalg.norm(corners - rough_px, axis=1)) <= stray_px else rough_px


def line_through(a_px: np.ndarray, b_px: np.ndarray, inside_px: np.ndarray) -> np.ndarray:
    """Homogeneous line through two points, unit normal, `inside_px` on its positive side."""
    line = np.cross([*a_px, 1.0], [*b_px, 1.0])
    line /= np.hypot(line[0], line[1])
    return line if line[:2] @ inside_px + line[2] >= 0 else -line


def detect_plate(
    roi_bgr: np.ndarray, mask: np.ndarray, offset_px: np.ndarray, params: PlateParams
) -> Plate | None:
    """The most plate-like blob of the vehicle's ROI, or None when no blob scores `min_score`.

    `roi_bgr`: the ROI crop (uint8 BGR); `mask`: its foreground (bool); `offset_px`: the ROI's top-left in the
    frame (x, y)."""
    grey = cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    mask = np.asarray(mask, dtype=bool)
    colour, seeds = (m & mask for m in plate_colour_masks(roi_bgr, params))
    best: tuple[np.ndarray, float, np.ndarray] | None = None
    for blob in filled_blobs(seeds, params.close_px):
        shape = plate_shape(blob, seeds, grey, params, roi_bgr.shape[1])
        if shape is not None and shape[1] >= params.min_score and (best is None or shape[1] > best[1]):
            best = (*shape, blob)
    if best is None:
        return None
    rough, score, blob = best
    corners = plate_corners(grey, blob, seeds, rough, params.edge_reach_fraction, params.min_fitted_side_px)
    corners = corners + np.asarray(offset_px, dtype=float)
    diagonals = np.cross(np.cross([*corners[0], 1.0], [*corners[2], 1.0]),
                         np.cross([*corners[1], 1.0], [*corners[3], 1.0]))
    centre = diagonals[:2] / diagonals[2]
    return Plate(
        corners_px=corners,
        centre_px=centre,
        upper_line_px=line_through(corners[0], corners[1], centre),
        lower_line_px=line_through(corners[3], corners[2], centre),
        score=score,
    )
