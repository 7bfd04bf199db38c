"""Lane-marker detection: painted white/yellow quadrilaterals and their corners at sub-pixel accuracy.

Steps: colour segmentation in HLS, blob analysis (connected components, convex quadrilateral fit),
then each side of a blob's quadrilateral is refined by locating the edge on intensity profiles
across it (the half-way crossing between paint and asphalt, interpolated between pixels) and fitting
a line; corners are the intersections of adjacent side lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import params_from_config


@dataclass(frozen=True)
class MarkerDetectionParams:
    """Thresholds of the marker detector (HLS in OpenCV's 8-bit ranges: H 0-180, L and S 0-255)."""

    white_min_contrast: int
    white_max_saturation: int
    tophat_kernel_fraction: float
    close_px: int
    yellow_hue_range: tuple[int, int]
    yellow_min_saturation: int
    yellow_min_lightness: int
    min_area_px: int
    min_side_px: float
    border_margin_px: int
    profile_half_length_px: float
    profile_samples_per_side: int
    min_fitted_side_px: float

    @classmethod
    def from_config(cls, **overrides: object) -> MarkerDetectionParams:
        """The settings of `conf/calibrate/detection/default.yaml`, with `overrides`."""
        return params_from_config(cls, "calibrate/detection/default.yaml", overrides)


@dataclass(frozen=True)
class DetectedMarker:
    """One detected marker blob: four corners (px), colour, area, and the sub-pixel edge points of each
    side (side k runs from corner k to corner k + 1; corners go clockwise on screen)."""

    corners_px: np.ndarray
    colour: str
    area_px: int
    side_points_px: tuple[np.ndarray, ...] = ()


def marker_masks(image_bgr: np.ndarray, params: MarkerDetectionParams) -> dict[str, np.ndarray]:
    """Binary masks (uint8 0/255) of white and yellow paint.

    White paint is found by its lightness above the local surface (a white top-hat with a disk wider
    than any marker), so that a bright road or a dim view does not need another threshold."""
    hue, lightness, saturation = cv2.split(cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HLS))
    kernel_px = max(5, int(round(params.tophat_kernel_fraction * image_bgr.shape[1])) | 1)
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (kernel_px, kernel_px))
    contrast = cv2.morphologyEx(lightness, cv2.MORPH_TOPHAT, disk)
    white = (contrast >= params.white_min_contrast) & (saturation <= params.white_max_saturation)
    low, high = params.yellow_hue_range
    yellow = (
        (hue >= low) & (hue <= high)
        & (saturation >= params.yellow_min_saturation)
        & (lightness >= params.yellow_min_lightness)
    )
    masks = {}
    for name, mask in (("white", white), ("yellow", yellow & ~white)):
        mask = cv2.morphologyEx(mask.astype(np.uint8) * 255, cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
        if params.close_px > 1:  # rejoin paint broken up by compression in low-resolution video
            mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((params.close_px,) * 2, np.uint8))
        masks[name] = mask
    return masks


def quadrilateral_of_blob(blob_mask: np.ndarray) -> np.ndarray | None:
    """Four vertices (px) approximating a blob's convex hull, or None if it is not a quadrilateral."""
    contours, _ = cv2.findContours(blob_mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    hull = cv2.convexHull(max(contours, key=cv2.contourArea))
    perimeter_px = cv2.arcLength(hull, True)
    for fraction in (0.01, 0.02, 0.03, 0.05, 0.08, 0.12):
        approx = cv2.approxPolyDP(hull, fraction * perimeter_px, True)
        if len(approx) == 4:
            return approx.reshape(4, 2).astype(float)
        if len(approx) < 4:
            return None
    return None


def _line_through(points_px: np.ndarray) -> np.ndarray:
    """Homogeneous line (a, b, c), a x + b y + c = 0, fitted to points by total least squares."""
    centre = points_px.mean(axis=0)
    _, _, vt = np.linalg.svd(points_px - centre)
    normal = vt[1]
    return np.array([normal[0], normal[1], -normal @ centre])


def _edge_points_of_side(
    grey: np.ndarray,
    start_px: np.ndarray,
    end_px: np.ndarray,
    outward: np.ndarray,
    paint_level: float,
    asphalt_level: float,
    params: MarkerDetectionParams,
) -> np.ndarray:
    """Sub-pixel points where intensity crosses half-way between paint and asphalt along one side."""
    from scipy.ndimage import map_coordinates  # scipy on first use: a refused CLI answers sooner
    length_px = np.linalg.norm(end_px - start_px)
    samples = max(3, min(params.profile_samples_per_side, int(length_px)))
    margin = 0.15 if length_px >= params.min_fitted_side_px else 0.3  # keep off the blurred corners
    along = np.linspace(margin, 1.0 - margin, samples)
    offsets = np.linspace(-params.profile_half_length_px, params.profile_half_length_px, 61)
    centres = start_px + along[:, None] * (end_px - start_px)
    points = centres[:, None, :] + offsets[None, :, None] * outward[None, None, :]
    profiles = map_coordinates(grey, [points[..., 1], points[..., 0]], order=1, mode="nearest")
    half_level = 0.5 * (paint_level + asphalt_level)
    edge_points = []
    for centre, profile in zip(centres, profiles):
        above = profile >= half_level
        crossings = np.flatnonzero(above[:-1] & ~above[1:])
        if len(crossings) == 0:
            continue
        i = crossings[np.argmin(np.abs(offsets[crossings]))]
        fraction = (profile[i] - half_level) / (profile[i] - profile[i + 1])
        offset = offsets[i] + fraction * (offsets[i + 1] - offsets[i])
        edge_points.append(centre + offset * outward)
    return np.array(edge_points).reshape(-1, 2)


def refine_quadrilateral(
    grey: np.ndarray, quad_px: np.ndarray, blob_mask: np.ndarray, params: MarkerDetectionParams
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Refine a blob's four vertices to sub-pixel corners from the edges of its four sides.

    Returns the corners and, per side, the edge points found on it."""
    quad = quad_px if _signed_area(quad_px) > 0 else quad_px[::-1]
    inside = blob_mask > 0
    ring = cv2.dilate(blob_mask, np.ones((7, 7), np.uint8)) > 0
    paint_level = float(np.median(grey[inside]))
    asphalt_level = float(np.median(grey[ring & ~inside])) if np.any(ring & ~inside) else 0.0
    lines, side_points = [], []
    for k in range(4):
        start, end = quad[k], quad[(k + 1) % 4]
        direction = (end - start) / np.linalg.norm(end - start)
        outward = np.array([direction[1], -direction[0]])  # right-hand normal of a CCW polygon (y down)
        points = _edge_points_of_side(grey, start, end, outward, paint_level, asphalt_level, params)
        side_points.append(points)
        if len(points) < 2:
            lines.append(np.cross([*start, 1.0], [*end, 1.0]))
        elif np.linalg.norm(end - start) < params.min_fitted_side_px or len(points) < 3:
            lines.append(np.array([outward[0], outward[1], -outward @ points.mean(axis=0)]))
        else:
            lines.append(_line_through(points))
    corners = []
    for k in range(4):
        corner = np.cross(lines[k - 1], lines[k])
        if abs(corner[2]) < 1e-12:
            return quad, side_points
        corners.append(corner[:2] / corner[2])
    corners = np.array(corners)
    if np.max(np.linalg.norm(corners - quad, axis=1)) > 3.0 + params.profile_half_length_px:
        return quad, side_points
    return corners, side_points


def _signed_area(polygon_px: np.ndarray) -> float:
    """Shoelace area; positive for counter-clockwise order in a y-up frame (clockwise on screen)."""
    x, y = polygon_px[:, 0], polygon_px[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def detect_markers(
    image_bgr: np.ndarray,
    params: MarkerDetectionParams | None = None,
    region_mask: np.ndarray | None = None,
) -> list[DetectedMarker]:
    """Detect painted markers with four visible corners; blobs touching the image border are skipped."""
    params = params or MarkerDetectionParams.from_config()
    if image_bgr.ndim != 3 or image_bgr.shape[2] != 3:
        raise ValueError(f"expected a BGR image of shape (H, W, 3), got {image_bgr.shape}")
    grey = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    height_px, width_px = grey.shape
    markers = []
    for colour, mask in marker_masks(image_bgr, params).items():
        if region_mask is not None:
            mask = cv2.bitwise_and(mask, region_mask)
        count, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        for label in range(1, count):
            x, y, w, h, area = stats[label]
            margin = params.border_margin_px
            if area < params.min_area_px or x < margin or y < margin:
                continue
            if x + w > width_px - margin or y + h > height_px - margin:
                continue
            blob = (labels[y:y + h, x:x + w] == label).astype(np.uint8) * 255
            quad = quadrilateral_of_blob(blob)
            if quad is None:
                continue
            sides = np.linalg.norm(quad - np.roll(quad, 1, axis=0), axis=1)
            if sides.min() < params.min_side_px:
                continue
            pad = int(np.ceil(params.profile_half_length_px)) + 4
            x0, y0 = max(0, x - pad), max(0, y - pad)
            x1, y1 = min(width_px, x + w + pad), min(height_px, y + h + pad)
            local_mask = (labels[y0:y1, x0:x1] == label).astype(np.uint8) * 255
            offset = np.array([x0, y0], dtype=float)
            corners, side_points = refine_quadrilateral(
                grey[y0:y1, x0:x1], quad + [x - x0, y - y0], local_mask, params
            )
            markers.append(
                DetectedMarker(corners + offset, colour, int(area), tuple(p + offset for p in side_points))
            )
    return markers
