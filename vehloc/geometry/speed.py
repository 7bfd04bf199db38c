"""A vehicle's speed from its path on the road: the least-squares constant-velocity motion through its reference
points, the speed's 1-sigma from the fit's residuals and from the calibration's scale.

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


@dataclass(frozen=True)
class SpeedFit:
    """A constant-velocity fit: the speed (km/h) and heading (deg) of the motion, the speed's 1-sigma (km/h) and
    its two shares, the points used, the time (s) and road distance (m) they span, and their residual (mm RMS)."""

    speed_kmh: float
    sigma_kmh: float
    fit_sigma_kmh: float
    scale_sigma_kmh: float
    heading_deg: float
    points: int
    duration_s: float
    distance_m: float
    residual_mm: float


def fit_speed(points_mm: np.ndarray, times_s: np.ndarray, scale_sigma_fraction: float, min_points: int,
              min_distance_mm: float) -> SpeedFit | NotPlaced:
    """The constant-velocity motion through road points (N, 2) mm seen at `times_s` (N,); a `NotPlaced` when fewer
    than `min_points` are finite or the motion covers less than `min_distance_mm`."""
    points = np.asarray(points_mm, dtype=float).reshape(-1, 2)
    times = np.asarray(times_s, dtype=float).reshape(-1)
    finite = np.all(np.isfinite(points), axis=1) & np.isfinite(times)
    points, times = points[finite], times[finite]
    if len(points) < max(min_points, 3):
        return NotPlaced(ReasonCode.PATH_TOO_SHORT,
                         f"its path has {len(points)} usable point(s), fewer than {max(min_points, 3)}")
    centred_t = times - times.mean()
    spread_s2 = float(centred_t @ centred_t)
    if spread_s2 <= 0.0:
        return NotPlaced(ReasonCode.PATH_TOO_SHORT, "its path's points are all of one instant")
    centred = points - points.mean(axis=0)
    velocity_mm_s = centred_t @ centred / spread_s2
    duration_s = float(times.max() - times.min())
    distance_mm = float(np.linalg.norm(velocity_mm_s)) * duration_s
    if distance_mm < min_distance_mm:
        return NotPlaced(ReasonCode.PATH_TOO_SHORT,
                         f"it moved {distance_mm / 1000:.1f} m while in view, less than {min_distance_mm / 1000:.1f} m")
    residuals = centred - np.outer(centred_t, velocity_mm_s)
    residual_mm = float(np.sqrt(np.sum(residuals**2) / (2 * len(points) - 4))) if len(points) > 2 else 0.0
    speed_kmh = float(np.linalg.norm(velocity_mm_s)) * MM_PER_S_TO_KMH
    fit_sigma_kmh = residual_mm / np.sqrt(spread_s2) * MM_PER_S_TO_KMH
    scale_sigma_kmh = speed_kmh * scale_sigma_fraction
    return SpeedFit(speed_kmh, float(np.hypot(fit_sigma_kmh, scale_sigma_kmh)), float(fit_sigma_kmh),
                    float(scale_sigma_kmh), heading_of(velocity_mm_s), len(points), duration_s, distance_mm / 1000.0,
                    residual_mm)
