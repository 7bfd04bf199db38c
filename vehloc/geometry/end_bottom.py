"""The bottom edge of a vehicle's end face below its licence plate, found where the end meets the road.

Below the end lies the road: in the vehicle's shade (darkest at the vehicle, lighter further out) or lit. The road's
pixels keep the road's chromaticity, and their light ratio (the frame's light over the background's) changes smoothly
towards the vehicle, falling towards it in the shade and never rising. The end's paint breaks one of these rules:
another chromaticity (a colour), a ratio that rises (a light body above the darkest shade), or one that falls far more
than the shade does from one pixel to the next (black paint). The silhouette only bounds how far down to look: its
texture test drops a bumper that carries a plate, and its chromaticity test bleeds with the frame's subsampled colour.

The profile: the ROI's pixels along the lines of the end's across direction (through its vanishing point), over the
end's middle (`EndBottomParams.span_plate_widths` plate widths either side of the vertical through P), one median per
whole-pixel step along that vertical, from the plate's lower edge down to a few pixels past the silhouette's bottom
(the road there sets the road's chromaticity). Walked up from the bottom, the first step that breaks the road's
rules is the end's, and the end's bottom edge lies half a pixel below it.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_range


@dataclass(frozen=True)
class EndBottomParams:
    """How wide the profile is and how far the road's pixels may depart from the road's rules, step by step."""

    span_plate_widths: float
    road_margin_px: int
    max_chroma_shift: float
    max_rise: float
    max_fall: float

    def __post_init__(self) -> None:
        check_range("span_plate_widths", self.span_plate_widths, 0.0, low_open=True)
        check_range("road_margin_px", self.road_margin_px, 1)
        for name in ("max_chroma_shift", "max_rise", "max_fall"):
            check_range(name, getattr(self, name), 0.0, low_open=True)


def _row_on_line(line: np.ndarray, y: float) -> np.ndarray:
    """The point (x, y) of a homogeneous image line at row `y` (the line not horizontal)."""
    a, b, c = line
    return np.array([-(b * y + c) / a, y])


def end_profile(roi_bgr: np.ndarray, light_ratio: np.ndarray, offset_px: np.ndarray, vertical_px: np.ndarray,
                across_vanishing_px: np.ndarray, half_span_px: float,
                rows_px: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The profile at the frame rows `rows_px` of the vertical line `vertical_px` (homogeneous): each row's log light
    ratio and chromaticity (B, G, R over their sum), the medians over the across line through that row's point of the
    vertical (towards `across_vanishing_px`, homogeneous) within `half_span_px` of it (NaN where it leaves the ROI)."""
    offset = np.asarray(offset_px, dtype=float)
    image = np.dstack([roi_bgr.astype(np.float32), light_ratio.astype(np.float32)])
    steps = np.arange(-np.floor(half_span_px), np.floor(half_span_px) + 1.0)
    samples = []
    for row in rows_px:
        point = _row_on_line(vertical_px, float(row))
        line = np.cross([*point, 1.0], across_vanishing_px)
        direction = np.array([line[1], -line[0]]) / np.hypot(line[0], line[1])
        along = point[None] + steps[:, None] * direction[None] - offset
        samples.append(along)
    grid = np.array(samples, dtype=np.float32)  # (rows, steps, 2) in ROI px
    values = cv2.remap(image, grid[..., 0], grid[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                       borderValue=(np.nan,) * 4)
    colour = values[..., :3]
    chroma = colour / (colour.sum(axis=2, keepdims=True) + 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        log_ratio = np.log(np.nanmedian(values[..., 3], axis=1))
        return log_ratio, np.nanmedian(chroma, axis=1)


def end_bottom_px(roi_bgr: np.ndarray, light_ratio: np.ndarray, mask: np.ndarray, offset_px: np.ndarray,
                  plate_bottom_px: np.ndarray, vertical_px: np.ndarray, across_vanishing_px: np.ndarray,
                  plate_width_px: float, params: EndBottomParams) -> np.ndarray | None:
    """Where the end's bottom edge crosses the vertical through the plate's middle (`vertical_px`, homogeneous), in
    frame px; `plate_bottom_px` is where the plate's lower edge crosses it. None when the silhouette does not reach
    below the plate there, or no step of the profile breaks the road's rules (grey paint about as dark as the lit
    road below it)."""
    offset = np.asarray(offset_px, dtype=float)
    half_span_px = params.span_plate_widths * plate_width_px
    top = int(np.ceil(plate_bottom_px[1]))
    columns = np.arange(int(np.floor(plate_bottom_px[0] - half_span_px)),
                        int(np.ceil(plate_bottom_px[0] + half_span_px)) + 1)
    inside = columns[(columns >= offset[0]) & (columns < offset[0] + mask.shape[1])] - int(offset[0])
    filled = mask[:, inside].any(axis=1)
    if not filled.any():
        return None
    bottom = min(int(np.flatnonzero(filled).max() + offset[1]) + params.road_margin_px,
                 int(offset[1]) + mask.shape[0] - 1)
    if bottom - top < 2:
        return None
    rows = np.arange(top, bottom + 1, dtype=float)
    log_ratio, chroma = end_profile(roi_bgr, light_ratio, offset, vertical_px, across_vanishing_px, half_span_px, rows)
    valid = np.isfinite(log_ratio) & np.all(np.isfinite(chroma), axis=1)
    rows, log_ratio, chroma = rows[valid], log_ratio[valid], chroma[valid]
    if len(rows) < 3:
        return None
    road_chroma = np.median(chroma[-params.road_margin_px:], axis=0)
    shift = np.abs(chroma - road_chroma).sum(axis=1)
    for i in range(len(rows) - 1, 0, -1):
        rise = log_ratio[i - 1] - log_ratio[i]
        if shift[i - 1] > params.max_chroma_shift or rise > params.max_rise or -rise > params.max_fall:
            return _row_on_line(vertical_px, rows[i] - 0.5)
    return None

