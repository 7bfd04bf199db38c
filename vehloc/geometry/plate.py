"""Licence plate in a vehicle ROI (paper, Sec. II-E): colour, then edges; its quadrilateral, its upper and lower
lines l_UL and l_LL, and its middle point P.

The plate's background colour is a rule in HSV: light plates with dark characters by default (low saturation,
lighter than their surroundings by a white top-hat whose kernel is a few times the plate's strokes), blue
Chinese plates with white characters by another hue, saturation and value range with the top-hat off. Where no
plate is found so, the plate's colour next to pixels darker than their surroundings by as much (its characters: a
plate on a body as light as the plate, `beside_characters`) is searched the same way. A closing
along the rows joins the plate's colour across the characters and the blobs' holes are filled. The characters
are the pixels of such a blob that are not plate-coloured, grouped into rows of parts of about the same height
side by side (characters too close to be told apart make one part, as wide as several), each part spanning most
of the row's height (the wedges between a wheel's spokes do not). Each row is the core of
a candidate plate, whose four sides are then found from the inside out on the image edges: every profile from
the core outwards crosses the plate's colour and then leaves it at the plate's edge, where the intensity passes
half-way between the plate's and the characters' levels, interpolated between samples. Starting inside, the
search is not misled by a lit strip of body that touches the plate. A candidate is a plate when its
quadrilateral has a plate's size and aspect, a plate's share of characters, its sides were found, and a row
through its middle crosses the characters. A small plate (a few pixels tall) has no room between its characters
and its edges to find the sides on: its sides are then the outline of its colour's blob (the closing has joined
it across the characters), lying along the image rows with characters inside, and tested the same way. P is
where the diagonals meet: the image of the plate's centre, whatever the perspective.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_interval, check_range, params_from_config
from vehloc.geometry.lamps import LampParams
from vehloc.geometry.silhouette import PIXEL_CORNERS

@dataclass(frozen=True)
class PlateParams:
    """Colour rule (OpenCV's 8-bit HSV: H 0-180, S and V 0-255), character rows, edges and plate tests, the
    widths and mounting heights a plate has (which the placement checks on the road), and the rear lamps beside it
    (whose heading the plate branch weighs against the body's lines)."""

    hue_range: tuple[int, int]
    saturation_range: tuple[int, int]
    value_range: tuple[int, int]
    min_contrast: float
    tophat_fraction: float
    beside_characters: bool
    close_px: tuple[int, int]
    min_characters: int
    run_together_aspect: float
    min_character_height_fraction: float
    edge_reach_fraction: float
    min_fitted_side_px: float
    max_side_residual_px: float
    small_max_height_px: float
    small_max_tilt_deg: float
    small_min_character_fraction: float
    min_width_px: float
    max_width_fraction: float
    aspect_range: tuple[float, float]
    character_fraction_range: tuple[float, float]
    min_crossings: int
    expected_crossings: int
    min_score: float
    width_range_mm: tuple[float, float]
    max_height_mm: float
    rear_lamps: LampParams

    def __post_init__(self) -> None:
        check_interval("hue_range", self.hue_range, 0, 180)  # OpenCV's 8-bit hue
        check_interval("saturation_range", self.saturation_range, 0, 255)
        check_interval("value_range", self.value_range, 0, 255)
        check_range("min_contrast", self.min_contrast, 0.0, 255.0)
        check_range("tophat_fraction", self.tophat_fraction, 0.0, 1.0, low_open=True)
        check_range("close_px[0]", self.close_px[0], 1)
        check_range("close_px[1]", self.close_px[1], 1)
        check_range("min_characters", self.min_characters, 1)
        check_range("run_together_aspect", self.run_together_aspect, 0.0, low_open=True)
        check_range("min_character_height_fraction", self.min_character_height_fraction, 0.0, 1.0)
        check_range("edge_reach_fraction", self.edge_reach_fraction, 0.0)
        for name in ("min_fitted_side_px", "max_side_residual_px", "small_max_height_px", "min_width_px"):
            check_range(name, getattr(self, name), 0.0)
        check_range("small_max_tilt_deg", self.small_max_tilt_deg, 0.0, 90.0)
        check_range("small_min_character_fraction", self.small_min_character_fraction, 0.0, 1.0)
        check_range("max_width_fraction", self.max_width_fraction, 0.0, 1.0, low_open=True)
        check_interval("aspect_range", self.aspect_range, 0.0, low_open=True)
        check_interval("character_fraction_range", self.character_fraction_range, 0.0, 1.0)
        check_range("min_crossings", self.min_crossings, 0)
        check_range("expected_crossings", self.expected_crossings, max(1, self.min_crossings))
        check_range("min_score", self.min_score, 0.0, 1.0)
        check_interval("width_range_mm", self.width_range_mm, 0.0, low_open=True)
        check_range("max_height_mm", self.max_height_mm, 0.0, low_open=True)

    @classmethod
    def from_config(cls, **overrides: object) -> PlateParams:
        """The settings of `conf/localize/plate/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/plate/default.yaml", overrides)


@dataclass(frozen=True, eq=False)
class Plate:
    """A detected licence plate in frame px.

    ``corners_px`` (4, 2): top-left, top-right, bottom-right, bottom-left as seen in the image (the edge of the
    plate's colour); ``centre_px``: P, where the diagonals meet; ``upper_line_px`` and ``lower_line_px``: l_UL
    and l_LL, homogeneous `a x + b y + c = 0` with `a^2 + b^2 = 1` and the plate on the positive side;
    ``score`` in [0, 1]: the share of the plate's four sides found on the image edges (a small plate's are its
    colour's outline) times how clearly a row through its middle crosses the characters; ``small``: its sides are
    its colour's outline (a small plate), not found on the image edges."""

    corners_px: np.ndarray
    centre_px: np.ndarray
    upper_line_px: np.ndarray
    lower_line_px: np.ndarray
    score: float
    small: bool = False


def plate_coloured(roi_bgr: np.ndarray, params: PlateParams, beside_characters: bool = False) -> np.ndarray:
    """Pixels (bool) of the plate's background colour: in the HSV ranges and, with the top-hat on, lighter than
    their surroundings; with `beside_characters`, instead next to (8-connected) a pixel darker than its
    surroundings by as much (the black top-hat, same kernel) and not such a pixel themselves: a light plate on a
    body as light as the plate, told only by its dark characters."""
    hue, saturation, value = cv2.split(cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2HSV))
    colour = np.ones(hue.shape, bool)
    for channel, (low, high) in ((hue, params.hue_range), (saturation, params.saturation_range),
                                 (value, params.value_range)):
        colour &= (channel >= low) & (channel <= high)
    if params.min_contrast <= 0:
        return colour
    size = max(3, int(round(params.tophat_fraction * roi_bgr.shape[1])) | 1)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (size, size))
    if not beside_characters:
        return colour & (cv2.morphologyEx(value, cv2.MORPH_TOPHAT, kernel) >= params.min_contrast)
    dark = cv2.morphologyEx(value, cv2.MORPH_BLACKHAT, kernel) >= params.min_contrast
    beside = cv2.dilate(dark.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    return colour & beside & ~dark


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


def character_rows(characters: np.ndarray, min_characters: int, run_together_aspect: float) -> list[np.ndarray]:
    """Rows (bool masks) of character-like parts: parts of about the same height (within a factor 1.5), level
    with each other (centres within half a height) and at most a height apart, chained; a row needs
    `min_characters` parts, or fewer that run together (the row `run_together_aspect` times wider than its tallest
    part: a small plate's characters merge into one or a few parts)."""
    count, labels, stats, centres = cv2.connectedComponentsWithStats(characters.astype(np.uint8), connectivity=8)
    parts = [k for k in range(1, count) if stats[k, cv2.CC_STAT_AREA] >= 2]
    group = {k: k for k in parts}

    def root(k: int) -> int:
        while group[k] != k:
            k = group[k]
        return k

    for i, a in enumerate(parts):
        for b in parts[i + 1:]:
            ha, hb = stats[a, cv2.CC_STAT_HEIGHT], stats[b, cv2.CC_STAT_HEIGHT]
            left = min(stats[a, cv2.CC_STAT_LEFT] + stats[a, cv2.CC_STAT_WIDTH], stats[b, cv2.CC_STAT_LEFT]
                       + stats[b, cv2.CC_STAT_WIDTH])
            gap = max(stats[a, cv2.CC_STAT_LEFT], stats[b, cv2.CC_STAT_LEFT]) - left
            if (max(ha, hb) <= 1.5 * min(ha, hb) and abs(centres[a, 1] - centres[b, 1]) <= max(ha, hb) / 2
                    and gap <= max(ha, hb)):
                group[root(b)] = root(a)
    rows = []
    for r in {root(k) for k in parts}:
        members = [k for k in parts if root(k) == r]
        left = stats[members, cv2.CC_STAT_LEFT]
        span_px = int((left + stats[members, cv2.CC_STAT_WIDTH]).max() - left.min())
        if len(members) >= min_characters or span_px >= run_together_aspect * stats[members, cv2.CC_STAT_HEIGHT].max():
            rows.append(np.isin(labels, members))
    return rows


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


def core_corners(row: np.ndarray) -> np.ndarray:
    """Corners (ordered) of the rotated rectangle around a row's pixel squares."""
    rows, cols = np.nonzero(row)
    squares = np.column_stack([cols, rows])[:, None, :] + PIXEL_CORNERS[None]
    return order_corners(cv2.boxPoints(cv2.minAreaRect(squares.reshape(-1, 2).astype(np.float32))).astype(float))


def character_height_fraction(row: np.ndarray, core: np.ndarray) -> float:
    """The mean extent of a row's parts across the row, as a fraction of the row's height: near 1 for characters,
    which all span the row, less for the wedges between a wheel's spokes."""
    across = core[3] - core[0]
    height_px = float(np.linalg.norm(across))
    count, labels = cv2.connectedComponents(row.astype(np.uint8), connectivity=8)
    spans = []
    for k in range(1, count):
        rows, cols = np.nonzero(labels == k)
        along = np.column_stack([cols, rows]) @ (across / height_px)
        spans.append(along.max() - along.min() + 1.0)
    return float(np.mean(spans)) / height_px


def edge_outwards(
    grey: np.ndarray, start_px: np.ndarray, end_px: np.ndarray, level: float, plate_above: bool, reach_px: float,
    min_fitted_px: float,
) -> tuple[np.ndarray, float] | None:
    """The line (homogeneous, unit normal) through the points where profiles leaving one side of the character
    core outwards first leave the plate's colour (the intensity passes `level` away from the plate's side after
    being on it), interpolated between samples: fitted to them on a side of `min_fitted_px` or more, else parallel
    to the side at their median offset; and the median distance (px) of the points from it. None when fewer than
    half the profiles leave the plate."""
    from scipy.ndimage import map_coordinates  # scipy on first use: a refused CLI answers sooner
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
        if len(leaving):
            i = leaving[0]
            fraction = profile[i] / (profile[i] - profile[i + 1])
            found.append((centre, offsets[i] + fraction * (offsets[i + 1] - offsets[i])))
    if 2 * len(found) < samples:
        return None
    points = np.array([centre + offset * outward for centre, offset in found])
    if np.linalg.norm(end_px - start_px) < min_fitted_px or len(found) < 3:
        through = start_px + float(np.median([offset for _, offset in found])) * outward
        line = np.array([outward[0], outward[1], -outward @ through])
    else:
        mean = points.mean(axis=0)
        normal = np.linalg.svd(points - mean)[2][1]
        line = np.array([normal[0], normal[1], -normal @ mean])
    return line, float(np.median(np.abs(points @ line[:2] + line[2])))


def plate_corners(
    grey: np.ndarray, core: np.ndarray, level: float, plate_above: bool, params: PlateParams
) -> tuple[np.ndarray, int] | None:
    """The plate's corners around a character core, from its four sides found outwards on the image edges (a side
    not found stays on the core), and how many sides were found; None when the top or the bottom edge is not
    straight (its points stray from its line by more than `max_side_residual_px`, median: a round rim, not a
    plate) or the sides do not meet."""
    reach_px = params.edge_reach_fraction * np.linalg.norm(core[3] - core[0])
    lines, found = [], 0
    for k in range(4):
        start, end = core[k], core[(k + 1) % 4]
        edge = edge_outwards(grey, start, end, level, plate_above, reach_px if k % 2 == 0 else 2 * reach_px,
                             params.min_fitted_side_px)
        if k % 2 == 0 and edge is not None and edge[1] > params.max_side_residual_px:
            return None
        found += edge is not None
        lines.append(edge[0] if edge is not None else np.cross([*start, 1.0], [*end, 1.0]))
    corners = np.array([np.cross(lines[k - 1], lines[k]) for k in range(4)])
    if np.any(np.abs(corners[:, 2]) < 1e-12):
        return None
    return corners[:, :2] / corners[:, 2:], found


def middle_row_crossings(grey: np.ndarray, corners_px: np.ndarray) -> int:
    """How often a row through the middle of the quadrilateral, from its left to its right side, crosses its own
    mean intensity: twice per character."""
    from scipy.ndimage import map_coordinates  # scipy on first use: a refused CLI answers sooner
    left, right = (corners_px[0] + corners_px[3]) / 2, (corners_px[1] + corners_px[2]) / 2
    samples = max(8, int(np.ceil(4 * np.linalg.norm(right - left))))
    points = left + np.linspace(0.1, 0.9, samples)[:, None] * (right - left)
    profile = map_coordinates(grey, [points[:, 1], points[:, 0]], order=1, mode="nearest")
    above = profile > profile.mean()
    return int(np.count_nonzero(above[1:] != above[:-1]))


def plate_score(
    grey: np.ndarray, plate_coloured: np.ndarray, corners: np.ndarray, sides_found: int, params: PlateParams,
    roi_width_px: int,
) -> float:
    """The plate score of a quadrilateral (see `Plate`), 0 when it has not a plate's size, aspect or share of
    characters or its middle row crosses too few of them."""
    width_px = (np.linalg.norm(corners[1] - corners[0]) + np.linalg.norm(corners[2] - corners[3])) / 2
    height_px = (np.linalg.norm(corners[3] - corners[0]) + np.linalg.norm(corners[2] - corners[1])) / 2
    if not params.min_width_px <= width_px <= params.max_width_fraction * roi_width_px:
        return 0.0
    if not params.aspect_range[0] <= width_px / max(height_px, 1e-9) <= params.aspect_range[1]:
        return 0.0
    inside = np.zeros(grey.shape, np.uint8)
    cv2.fillPoly(inside, [np.round(corners * 16).astype(np.int32)], 1, cv2.LINE_8, 4)
    characters = 1.0 - plate_coloured[inside.astype(bool)].mean() if inside.any() else 0.0
    crossings = middle_row_crossings(grey, corners)
    low, high = params.character_fraction_range
    if not low <= characters <= high or crossings < params.min_crossings:
        return 0.0
    return sides_found / 4 * min(1.0, crossings / params.expected_crossings)


def line_through(a_px: np.ndarray, b_px: np.ndarray, inside_px: np.ndarray) -> np.ndarray:
    """Homogeneous line through two points, unit normal, `inside_px` on its positive side."""
    line = np.cross([*a_px, 1.0], [*b_px, 1.0])
    line /= np.hypot(line[0], line[1])
    return line if line[:2] @ inside_px + line[2] >= 0 else -line


def small_plate_corners(blob: np.ndarray, seeds: np.ndarray, params: PlateParams) -> np.ndarray | None:
    """The corners of a small plate's blob (its colour joined across the characters, holes filled): the rotated
    rectangle around its pixel squares; None when it is taller than `small_max_height_px`, its long sides are
    more than `small_max_tilt_deg` off the image rows (a plate's characters stand side by side), or less than
    `small_min_character_fraction` of it is not plate-coloured (no characters in it)."""
    corners = core_corners(blob)
    height_px = (np.linalg.norm(corners[3] - corners[0]) + np.linalg.norm(corners[2] - corners[1])) / 2
    dx, dy = corners[1] - corners[0]
    characters = np.count_nonzero(blob & ~seeds) / np.count_nonzero(blob)
    if (height_px > params.small_max_height_px or np.degrees(np.arctan2(abs(dy), abs(dx))) > params.small_max_tilt_deg
            or characters < params.small_min_character_fraction):
        return None
    return corners


def plate_candidates(
    roi_bgr: np.ndarray, mask: np.ndarray, offset_px: np.ndarray, params: PlateParams
) -> list[Plate]:
    """The plates of the vehicle's ROI scoring at least `min_score`, best first (on a tie, the one whose sides
    were found on the edges).

    `roi_bgr`: the ROI crop (uint8 BGR); `mask`: its foreground (bool); `offset_px`: the ROI's top-left in the
    frame (x, y)."""
    grey = cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    scored = scored_plates(roi_bgr, grey, plate_coloured(roi_bgr, params) & np.asarray(mask, dtype=bool), params)
    if not scored and params.beside_characters and params.min_contrast > 0:
        seeds = plate_coloured(roi_bgr, params, beside_characters=True) & np.asarray(mask, dtype=bool)
        scored = scored_plates(roi_bgr, grey, seeds, params)
    return [plate_from_corners(corners + np.asarray(offset_px, dtype=float), score, small)
            for score, corners, small in scored]


def scored_plates(
    roi_bgr: np.ndarray, grey: np.ndarray, seeds: np.ndarray, params: PlateParams
) -> list[tuple[float, np.ndarray, bool]]:
    """The quadrilaterals (ROI px) around the character rows of the plate-coloured `seeds` scoring at least
    `min_score`, best first, each with its score and whether its sides are its colour's outline (a small plate)."""
    scored: list[tuple[float, np.ndarray, bool]] = []
    for blob in filled_blobs(seeds, params.close_px):
        quads = []
        for row in character_rows(blob & ~seeds, params.min_characters, params.run_together_aspect):
            core = core_corners(row)
            if character_height_fraction(row, core) < params.min_character_height_fraction:
                continue
            near = cv2.dilate(row.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool) & blob & seeds
            if not near.any():
                continue
            plate_level, characters_level = float(np.median(grey[near])), float(np.median(grey[row]))
            found = plate_corners(grey, core, (plate_level + characters_level) / 2,
                                  plate_level > characters_level, params)
            if found is not None:
                quads.append((*found, False))
        small = small_plate_corners(blob, seeds, params)
        if small is not None:
            quads.append((small, 4, True))
        for corners, sides_found, from_outline in quads:
            score = plate_score(grey, seeds, corners, sides_found, params, roi_bgr.shape[1])
            if score >= params.min_score:
                scored.append((score, corners, from_outline))
    scored.sort(key=lambda item: -item[0])
    return scored


def plate_from_corners(corners: np.ndarray, score: float, small: bool = False) -> Plate:
    """The plate of frame corners (ordered): P where the diagonals meet, the upper and lower lines; `small` when
    the corners are its colour's outline."""
    diagonals = np.cross(np.cross([*corners[0], 1.0], [*corners[2], 1.0]),
                         np.cross([*corners[1], 1.0], [*corners[3], 1.0]))
    centre = diagonals[:2] / diagonals[2]
    return Plate(
        corners_px=corners,
        centre_px=centre,
        upper_line_px=line_through(corners[0], corners[1], centre),
        lower_line_px=line_through(corners[3], corners[2], centre),
        score=float(score),
        small=small,
    )


def detect_plate(
    roi_bgr: np.ndarray, mask: np.ndarray, offset_px: np.ndarray, params: PlateParams
) -> Plate | None:
    """The best-scoring plate of the vehicle's ROI (`plate_candidates`), or None when none scores `min_score`."""
    candidates = plate_candidates(roi_bgr, mask, offset_px, params)
    return candidates[0] if candidates else None
