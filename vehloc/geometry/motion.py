"""A moving vehicle's heading from its path on the road: the road points under its box's bottom over its last
frames, their principal direction, pointed the way the vehicle went, and that direction's 1-sigma uncertainty.

The uncertainty is the straight-line fit's: the points' spread across the path over the square root of their
spread along it. The spread comes from the jitter of the box's bottom in the image: measured as the points'
residuals about a vehicle moving at constant speed along a straight line (in pixels, both image directions),
never taken below `jitter_px` (two points have no residual), and turned into millimetres across the path on the
road where each point lies (a far vehicle's pixel spans a lot of road). A box whose bottom jumps, as when a
neighbour joins the blob or the blob loses its lower part, thus makes its path uncertain even when the points
happen to lie on one line.

Which way along that direction the vehicle went is the sign of its speed along it (the least-squares constant-speed
motion's); the speed's distance from zero in its own sigmas (the same jitter, turned into millimetres along the
path) says how sure that way is: a box whose bottom wanders back and forth gives a path that does not tell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.placement import heading_of
from vehloc.geometry.projective import ProjectiveTransform


@dataclass(frozen=True)
class PathHeading:
    """The heading (deg) a path points in, the way the vehicle went along it, its 1-sigma (deg), the box bottom's
    jitter it was taken with (px), the points' count and extent along the path (mm), and the speed along the path
    in its own sigmas (how sure the way is)."""

    heading_deg: float
    sigma_deg: float
    jitter_px: float
    points: int
    extent_mm: float
    speed_sigmas: float


def recent_path(points_mm: list[np.ndarray], frames: list[int], frame_index: int, window_frames: int,
                max_gap_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(N, 2) road points and (N,) frames of the last `window_frames` frames up to `frame_index`, since the last
    gap of more than `max_gap_frames` frames between two of them (across a longer gap the track may have changed
    vehicle)."""
    kept = [(f, p) for p, f in zip(points_mm, frames) if frame_index - window_frames < f <= frame_index]
    start = 0
    for i in range(1, len(kept)):
        if kept[i][0] - kept[i - 1][0] > max_gap_frames:
            start = i
    kept = kept[start:]
    return np.array([p for _, p in kept], dtype=float).reshape(-1, 2), np.array([f for f, _ in kept], dtype=float)


def box_bottom_jitter_px(points_mm: np.ndarray, frames: np.ndarray, px_per_mm: np.ndarray) -> float:
    """The 1-sigma (px, per image direction) of the points about the least-squares constant-speed straight
    motion through them, their residuals mapped into the image by `px_per_mm`, the road-to-image Jacobians
    (N, 2, 2) at the points; 0 for two points."""
    count = len(points_mm)
    if count < 3:
        return 0.0
    centred = points_mm - points_mm.mean(axis=0)
    time = frames - frames.mean()
    velocity_mm = time @ centred / (time @ time)
    residual_px = np.einsum("nij,nj->ni", px_per_mm, centred - np.outer(time, velocity_mm))
    return float(np.sqrt(np.sum(residual_px**2) / (2 * count - 4)))


def path_heading(points_mm: np.ndarray, frames: np.ndarray, min_extent_mm: float, road_to_image: ProjectiveTransform,
                 jitter_px: float) -> PathHeading | None:
    """The heading of a path of road points seen at `frames` (their principal direction, pointed the way the
    constant-speed motion through them goes) and its 1-sigma; None when fewer than two are finite or they spread
    less than `min_extent_mm` along it."""
    points = np.asarray(points_mm, dtype=float).reshape(-1, 2)
    finite = np.all(np.isfinite(points), axis=1)
    points, frames = points[finite], np.asarray(frames, dtype=float)[finite]
    if len(points) < 2:
        return None
    centred = points - points.mean(axis=0)
    direction = np.linalg.svd(centred, full_matrices=False)[2][0]
    along = centred @ direction
    extent_mm = float(along.max() - along.min())
    if extent_mm < min_extent_mm:
        return None
    px_per_mm = road_to_image.jacobian(points)
    jitter_px = max(jitter_px, box_bottom_jitter_px(points, frames, px_per_mm))
    across = np.array([-direction[1], direction[0]])
    per_px_mm = np.linalg.inv(px_per_mm).transpose(0, 2, 1)  # (N, 2, 2): mm per x, y px
    across_var_mm2 = jitter_px**2 * float(np.mean(np.sum((per_px_mm @ across) ** 2, axis=1)))
    along_var_mm2 = jitter_px**2 * float(np.mean(np.sum((per_px_mm @ direction) ** 2, axis=1)))
    sigma_rad = np.sqrt(across_var_mm2 / float(np.sum(along**2)))
    time = frames - frames.mean()
    speed_mm_per_frame = float(time @ along / (time @ time))
    speed_sigmas = abs(speed_mm_per_frame) / np.sqrt(along_var_mm2 / (time @ time))
    pointed = direction if speed_mm_per_frame >= 0 else -direction
    return PathHeading(heading_of(pointed), float(np.degrees(sigma_rad)), jitter_px, len(points), extent_mm,
                       float(speed_sigmas))
