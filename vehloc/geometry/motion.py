"""A moving vehicle's heading from its path on the road: the road points under its box's bottom over its last
frames, their principal direction, and that direction's 1-sigma uncertainty.

The uncertainty is the straight-line fit's: the spread of the points across the path over the square root of
their spread along it. The spread across is measured from the points' residuals, and is never taken below what
`jitter_px` of the box's bottom in the image makes across the path on the road (two points have no residual,
and a far vehicle's pixel spans a lot of road).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.placement import heading_of
from vehloc.geometry.projective import ProjectiveTransform


@dataclass(frozen=True)
class PathHeading:
    """The heading (deg) a path points in, from its first point towards its last, its 1-sigma (deg), and the
    points' count and extent along it (mm)."""

    heading_deg: float
    sigma_deg: float
    points: int
    extent_mm: float


def recent_path(points_mm: list[np.ndarray], frames: list[int], frame_index: int, window_frames: int,
                max_gap_frames: int) -> np.ndarray:
    """(N, 2) road points of the last `window_frames` frames up to `frame_index`, since the last gap of more
    than `max_gap_frames` frames between two of them (across a longer gap the track may have changed vehicle)."""
    kept = [(f, p) for p, f in zip(points_mm, frames) if frame_index - window_frames < f <= frame_index]
    start = 0
    for i in range(1, len(kept)):
        if kept[i][0] - kept[i - 1][0] > max_gap_frames:
            start = i
    return np.array([p for _, p in kept[start:]], dtype=float).reshape(-1, 2)


def path_heading(points_mm: np.ndarray, min_extent_mm: float, road_to_image: ProjectiveTransform,
                 jitter_px: float) -> PathHeading | None:
    """The heading of a path of road points (their principal direction, pointed from the first towards the last)
    and its 1-sigma; None when fewer than two are finite or they spread less than `min_extent_mm` along it."""
    points = np.asarray(points_mm, dtype=float).reshape(-1, 2)
    points = points[np.all(np.isfinite(points), axis=1)]
    if len(points) < 2:
        return None
    centred = points - points.mean(axis=0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    along = centred @ direction
    extent_mm = float(along.max() - along.min())
    if extent_mm < min_extent_mm:
        return None
    across = np.array([-direction[1], direction[0]])
    residual_var_mm2 = float(np.sum((centred @ across) ** 2)) / (len(points) - 2) if len(points) > 2 else 0.0
    per_px_mm = road_to_image.inverse.jacobian(road_to_image(points)).transpose(0, 2, 1) @ across  # (N, 2): x, y px
    jitter_var_mm2 = jitter_px**2 * float(np.mean(np.sum(per_px_mm**2, axis=1)))
    sigma_rad = np.sqrt(max(residual_var_mm2, jitter_var_mm2) / float(np.sum(along**2)))
    pointed = direction if along[-1] >= along[0] else -direction
    return PathHeading(heading_of(pointed), float(np.degrees(sigma_rad)), len(points), extent_mm)
