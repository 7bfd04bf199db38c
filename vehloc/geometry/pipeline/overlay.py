"""Drawings over camera images: detected markers, matched corners, the world grid projected back."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import cv2
import numpy as np

from vehloc.geometry.calibration import Calibration
from vehloc.geometry.markers import DetectedMarker

SHIFT = 4
SCALE = 1 << SHIFT


def _pt(point_px: np.ndarray) -> tuple[int, int]:
    return int(round(point_px[0] * SCALE)), int(round(point_px[1] * SCALE))


def draw_grid(image: np.ndarray, road_to_image: Callable[[np.ndarray], np.ndarray], extent_mm: np.ndarray,
              step_mm: float = 1000.0) -> None:
    """Draw road-plane grid lines every `step_mm` over extent [[x0, y0], [x1, y1]] (mm)."""
    (x0, y0), (x1, y1) = np.floor(extent_mm[0] / step_mm) * step_mm, np.ceil(extent_mm[1] / step_mm) * step_mm
    segments = [((x, y0), (x, y1)) for x in np.arange(x0, x1 + 1, step_mm)]
    segments += [((x0, y), (x1, y)) for y in np.arange(y0, y1 + 1, step_mm)]
    for start, end in segments:
        samples = np.linspace(start, end, 50)
        pixels = road_to_image(samples)
        ok = np.all(np.isfinite(pixels), axis=1) & (np.abs(pixels) < 1e5).all(axis=1)
        for a, b in zip(pixels[:-1][ok[:-1] & ok[1:]], pixels[1:][ok[:-1] & ok[1:]]):
            cv2.line(image, _pt(a), _pt(b), (255, 200, 0), 1, cv2.LINE_AA, SHIFT)


def draw_calibration(
    image_bgr: np.ndarray, markers: Sequence[DetectedMarker], calibration: Calibration, step_mm: float = 1000.0
) -> np.ndarray:
    """Overlay: the world grid (cyan), detected quads (green), inlier corners (red) with their
    surveyed corners projected by H (yellow crosses), outliers (magenta)."""
    canvas = image_bgr.copy()
    margin_mm = 2 * step_mm
    extent = np.array([calibration.world_mm.min(axis=0) - margin_mm, calibration.world_mm.max(axis=0) + margin_mm])
    draw_grid(canvas, calibration.road_to_image, extent, step_mm)
    for marker in markers:
        cv2.polylines(canvas, [np.round(marker.corners_px * SCALE).astype(np.int32)], True, (0, 200, 0), 1, cv2.LINE_AA, SHIFT)
    projected = calibration.road_to_image(calibration.world_mm)
    for detected, surveyed, inlier in zip(calibration.image_px, projected, calibration.inliers):
        colour = (0, 0, 255) if inlier else (255, 0, 255)
        cv2.circle(canvas, _pt(detected), 3 * SCALE, colour, 1, cv2.LINE_AA, SHIFT)
        cv2.drawMarker(canvas, tuple(int(v) for v in np.round(surveyed)), (0, 255, 255), cv2.MARKER_CROSS, 7, 1)
    return canvas
