"""A vehicle's two rear lamps either side of its licence plate: a horizontal line across its rear end.

The rear lamps are red, saturated and lit (OpenCV's 8-bit HSV: red hues either side of 0, high saturation and value),
one either side of the plate and alike in size. The line through their middles is level and across the vehicle, as
the plate's edges are, over a baseline three or four times the plate's width: its road direction (the inverse
homography keeps a level line's direction) gives the vehicle's across axis more closely than a small plate's edges.
A red body joins its lamps into one large part; two parts much unlike in size, or two the plate does not stand
between, are no pair, and none is returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import SettingError, check_interval, check_range


@dataclass(frozen=True)
class LampParams:
    """What a rear lamp looks like and how alike the two must be (`plate.rear_lamps` of `conf/localize/plate/`)."""

    enabled: bool
    hue_ranges: tuple[tuple[int, int], ...]
    min_saturation: int
    min_value: int
    min_area_px: int
    max_area_ratio: float
    max_off_middle: float

    def __post_init__(self) -> None:
        if not self.hue_ranges:
            raise SettingError("hue_ranges", "needs at least one range of hues")
        for k, hues in enumerate(self.hue_ranges):
            check_interval(f"hue_ranges[{k}]", hues, 0, 180)  # OpenCV's 8-bit hue
        check_range("min_saturation", self.min_saturation, 0, 255)
        check_range("min_value", self.min_value, 0, 255)
        check_range("min_area_px", self.min_area_px, 1)
        check_range("max_area_ratio", self.max_area_ratio, 1.0)
        check_range("max_off_middle", self.max_off_middle, 0.0, 0.5)


@dataclass(frozen=True)
class LampPair:
    """The two lamps' middles (frame px, left then right on screen) and the line through them (homogeneous, unit
    normal)."""

    centres_px: np.ndarray
    line_px: np.ndarray


def lamp_coloured(roi_bgr: np.ndarray, params: LampParams) -> np.ndarray:
    """Pixels (bool) of a rear lamp's colour: a hue in one of the ranges, saturated and light enough."""
    hue, saturation, value = cv2.split(cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2HSV))
    in_hue = np.zeros(hue.shape, bool)
    for low, high in params.hue_ranges:
        in_hue |= (hue >= low) & (hue <= high)
    return in_hue & (saturation >= params.min_saturation) & (value >= params.min_value)


def rear_lamps(roi_bgr: np.ndarray, mask: np.ndarray, offset_px: np.ndarray, between_px: np.ndarray,
               params: LampParams) -> LampPair | None:
    """The vehicle's rear lamps either side of `between_px` (frame px, the plate's middle): the largest lamp-coloured
    part of the silhouette `mask` left of it and the largest right of it, each at least `min_area_px`; None when
    either side has none, the larger is more than `max_area_ratio` times the smaller, or `between_px` lies further
    than `max_off_middle` of their separation from their midpoint, along the line through them (the plate stands
    in the end's middle)."""
    offset = np.asarray(offset_px, dtype=float)
    lamp = lamp_coloured(roi_bgr, params) & np.asarray(mask, dtype=bool)
    count, _, stats, centres = cv2.connectedComponentsWithStats(lamp.astype(np.uint8), connectivity=8)
    areas = stats[:, cv2.CC_STAT_AREA]
    parts = [k for k in range(1, count) if areas[k] >= params.min_area_px]
    middle_x = float(between_px[0] - offset[0])
    left = [k for k in parts if centres[k, 0] < middle_x]
    right = [k for k in parts if centres[k, 0] > middle_x]
    if not left or not right:
        return None
    pair = [max(left, key=lambda k: areas[k]), max(right, key=lambda k: areas[k])]
    if max(areas[pair]) > params.max_area_ratio * min(areas[pair]):
        return None
    middles = centres[pair] + offset
    along = middles[1] - middles[0]
    off_middle_px2 = abs((np.asarray(between_px, dtype=float) - middles.mean(axis=0)) @ along)
    if off_middle_px2 > params.max_off_middle * (along @ along):
        return None
    line = np.cross([*middles[0], 1.0], [*middles[1], 1.0])
    return LampPair(middles, line / np.hypot(line[0], line[1]))
