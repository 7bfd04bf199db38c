"""A vehicle's speed from its path on the road: the least-squares constant-velocity motion through its reference
points, the points that stray from it dropped (a box that held a neighbour for a few frames), the speed's 1-sigma
from the fit's residuals and from the calibration's scale.

The strays are found from a start that they cannot pull (least median of squares over the motions through pairs of
points half the path apart in time): those farther from the motion than `OUTLIER_SIGMAS` times the residuals' robust
spread (1.4826 times their median, never taken below `MIN_SPREAD_MM`), the motion refitted by least squares without
them until the set kept no longer changes.

The fit's share is the velocity's standard error along the motion: the residuals' spread (mm, per road axis) over the
square root of the times' spread. The residuals of consecutive frames are correlated (a box's bottom wanders slowly),
so this share is a lower bound; the scale's share (a relative error of the calibration turns every distance, and so
the speed, by the same fraction) is usually the larger one over a long path.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.placement import heading_of

MM_PER_S_TO_KMH = 3.6e-3
OUTLIER_SIGMAS = 3.5
MIN_SPREAD_MM = 50.0
MAX_REFITS = 5


@dataclass(frozen=True, eq=False)
class SpeedFit:
    """A constant-velocity fit: the speed (km/h) and heading (deg) of the motion, the speed's 1-sigma (km/h) and
    its two shares, the points used and dropped, the time (s) and road distance (m) the used ones span, and their
    residual (mm RMS)."""

    speed_kmh: float
    sigma_kmh: float
    fit_sigma_kmh: float
    scale_sigma_kmh: float
    heading_deg: float
    points: int
    duration_s: float
    distance_m: float
    residual_mm: float
    dropped: int
    used: np.ndarray
    """(N,) bool: which of the points given were used (finite and not strays)."""
    origin_mm: np.ndarray
    """(2,) the motion's road position at time 0 (mm)."""
    velocity_mm_s: np.ndarray
    """(2,) the motion's velocity on the road (mm/s)."""

    def positions_mm(self, times_s: np.ndarray) -> np.ndarray:
        """(N, 2) where the motion puts the vehicle at `times_s` (N,), mm."""
        return self.origin_mm + np.outer(np.asarray(times_s, dtype=float), self.velocity_mm_s)


def fit_speed(points_mm: np.ndarray, times_s: np.ndarray, scale_sigma_fraction: float, min_points: int,
              min_distance_mm: float) -> SpeedFit | NotPlaced:
    """The constant-velocity motion through road points (N, 2) mm seen at `times_s` (N,); a `NotPlaced` when fewer
    than `min_points` are finite or the motion covers less than `min_distance_mm`."""
    points = np.asarray(points_mm, dtype=float).reshape(-1, 2)
    times = np.asarray(times_s, dtype=float).reshape(-1)
    finite = np.all(np.isfinite(points), axis=1) & np.isfinite(times)
    points, times = points[finite], times[finite]
    needed = max(min_points, 3)
    if len(points) < needed:
        return NotPlaced(ReasonCode.PATH_TOO_SHORT, f"its path has {len(points)} usable point(s), fewer than {needed}")
    if float(np.ptp(times)) <= 0.0:
        return NotPlaced(ReasonCode.PATH_TOO_SHORT, "its path's points are all of one instant")
    kept = np.ones(len(points), bool)
    origin_mm, velocity_mm_s = _least_median_motion(points, times)
    for _ in range(MAX_REFITS):
        distances = np.linalg.norm(points - origin_mm - np.outer(times, velocity_mm_s), axis=1)
        spread_mm = max(MIN_SPREAD_MM, 1.4826 * float(np.median(distances[kept])))
        inliers = distances <= OUTLIER_SIGMAS * spread_mm
        if np.array_equal(inliers, kept) or inliers.sum() < needed or np.ptp(times[inliers]) <= 0.0:
            break
        kept = inliers
        origin_mm, velocity_mm_s = _motion(points[kept], times[kept])
    dropped = int(len(points) - kept.sum())
    used = np.zeros(len(finite), bool)
    used[np.flatnonzero(finite)[kept]] = True
    points, times = points[kept], times[kept]
    centred_t = times - times.mean()
    spread_s2 = float(centred_t @ centred_t)
    centred = points - points.mean(axis=0)
    velocity_mm_s = centred_t @ centred / spread_s2
    duration_s = float(times.max() - times.min())
    distance_mm = float(np.linalg.norm(velocity_mm_s)) * duration_s
    if distance_mm < min_distance_mm:
        return NotPlaced(ReasonCode.PATH_TOO_SHORT,
                         f"its steady motion covers {distance_mm / 1000:.1f} m over the {len(points)} points that fit it, "
                         f"less than {min_distance_mm / 1000:.1f} m (a vehicle that stops has no single speed)")
    residuals = centred - np.outer(centred_t, velocity_mm_s)
    residual_mm = float(np.sqrt(np.sum(residuals**2) / (2 * len(points) - 4)))  # 4 parameters: origin, velocity
    speed_kmh = float(np.linalg.norm(velocity_mm_s)) * MM_PER_S_TO_KMH
    fit_sigma_kmh = residual_mm / np.sqrt(spread_s2) * MM_PER_S_TO_KMH
    scale_sigma_kmh = speed_kmh * scale_sigma_fraction
    return SpeedFit(speed_kmh, float(np.hypot(fit_sigma_kmh, scale_sigma_kmh)), float(fit_sigma_kmh),
                    float(scale_sigma_kmh), heading_of(velocity_mm_s), len(points), duration_s, distance_mm / 1000.0,
                    residual_mm, dropped, used, points.mean(axis=0) - times.mean() * velocity_mm_s, velocity_mm_s)


def _least_median_motion(points_mm: np.ndarray, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Of the least-squares motion and the motions through pairs of points half the path apart in time, the one whose
    points' median distance from it is the least: its position at time 0 (mm) and velocity (mm/s)."""
    order = np.argsort(times_s, kind="stable")
    half = len(order) // 2
    first, second = order[: len(order) - half], order[half:]
    gaps_s = times_s[second] - times_s[first]
    usable = gaps_s > 0
    velocities = (points_mm[second] - points_mm[first])[usable] / gaps_s[usable, None]
    origins = points_mm[first][usable] - times_s[first][usable, None] * velocities
    origin, velocity = _motion(points_mm, times_s)
    origins, velocities = np.vstack([origin, origins]), np.vstack([velocity, velocities])
    predicted = origins[:, None, :] + times_s[None, :, None] * velocities[:, None, :]
    best = int(np.argmin(np.median(np.linalg.norm(points_mm[None] - predicted, axis=2), axis=1)))
    return origins[best], velocities[best]


def _motion(points_mm: np.ndarray, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares constant-velocity motion through the points: its position at time 0 (mm) and its velocity
    (mm/s)."""
    mean_t = times_s.mean()
    centred_t = times_s - mean_t
    velocity = centred_t @ (points_mm - points_mm.mean(axis=0)) / float(centred_t @ centred_t)
    return points_mm.mean(axis=0) - mean_t * velocity, velocity
