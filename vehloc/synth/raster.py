"""Polygon filling with sub-pixel vertices: anti-aliased, or supersampled for exact pixel coverage."""

from __future__ import annotations

import cv2
import numpy as np

SUBPIXEL_SHIFT = 4  # cv2 drawing with 1/16 px vertex precision


def fill_polygon_px(
    image: np.ndarray, polygon_px: np.ndarray, colour: tuple[int, ...] | int, supersample: int = 1
) -> None:
    """Fill a polygon with sub-pixel vertices (pixel centres at integer coordinates).

    With `supersample` > 1 the polygon is drawn on a finer grid and area-averaged, so edge pixels get
    their exact coverage; OpenCV's LINE_AA fill spreads edges about a pixel outwards, which is fine
    for scenery but not for marker corners that serve as ground truth.
    """
    if len(polygon_px) < 3:
        return
    limit_px = 1 << 14  # keep far-off vertices inside cv2's fixed-point range
    polygon = np.clip(np.asarray(polygon_px, dtype=float), -limit_px, limit_px)
    if supersample <= 1:
        points = np.round(polygon * (1 << SUBPIXEL_SHIFT)).astype(np.int32)
        cv2.fillPoly(image, [points], colour, cv2.LINE_AA, SUBPIXEL_SHIFT)
        return
    height_px, width_px = image.shape[:2]
    x0, y0 = np.maximum(np.floor(polygon.min(axis=0)).astype(int) - 1, 0)
    x1 = min(int(np.ceil(polygon[:, 0].max())) + 2, width_px)
    y1 = min(int(np.ceil(polygon[:, 1].max())) + 2, height_px)
    if x1 <= x0 or y1 <= y0:
        return
    fine = np.zeros(((y1 - y0) * supersample, (x1 - x0) * supersample), np.uint8)
    fine_points = ((polygon - [x0, y0] + 0.5) * supersample - 0.5) * (1 << SUBPIXEL_SHIFT)
    cv2.fillPoly(fine, [np.round(fine_points).astype(np.int32)], 255, cv2.LINE_8, SUBPIXEL_SHIFT)
    coverage = cv2.resize(fine, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA).astype(np.float32) / 255
    patch = image[y0:y1, x0:x1].astype(np.float32)
    if patch.ndim == 3:
        coverage = coverage[..., None]
    blended = patch * (1 - coverage) + np.asarray(colour, dtype=np.float32) * coverage
    image[y0:y1, x0:x1] = np.round(blended).astype(image.dtype)
