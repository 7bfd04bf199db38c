"""Where many image segments meet: a vanishing point found robustly (RANSAC over pairs, then the weighted least
squares of the angles of the consenting segments), in homogeneous pixels so that a point at infinity (parallel
segments) is a value like any other. A set of segments that agrees on no point is a `FailedEstimate`, not an
exception."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.outcome import FailedEstimate

REFINE_ITERATIONS = 5


@dataclass(frozen=True)
class Segments:
    """Image segments: a point on each (N, 2 px), its unit direction (N, 2) and its weight (N,), e.g. its length."""

    points_px: np.ndarray
    directions: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.points_px)
        if self.points_px.shape != (n, 2) or self.directions.shape != (n, 2) or self.weights.shape != (n,):
            raise ValueError("segments need points (N, 2), directions (N, 2) and weights (N,)")

    @classmethod
    def empty(cls) -> Segments:
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))

    @classmethod
    def join(cls, parts: list[Segments]) -> Segments:
        parts = [p for p in parts if len(p)] or [cls.empty()]
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in ("points_px", "directions", "weights")))

    def __len__(self) -> int:
        return len(self.points_px)

    def subset(self, keep: np.ndarray) -> Segments:
        return Segments(self.points_px[keep], self.directions[keep], self.weights[keep])

    def sin_to(self, point_h: np.ndarray) -> np.ndarray:
        """|sin| of the angle between each segment and the line from its point to the homogeneous image point
        `point_h` (x, y, w); 1 where the point is the segment's own."""
        towards = point_h[None, :2] - point_h[2] * self.points_px
        norm = np.linalg.norm(towards, axis=1)
        cross = np.abs(self.directions[:, 0] * towards[:, 1] - self.directions[:, 1] * towards[:, 0])
        return np.where(norm > 0, cross / np.where(norm > 0, norm, 1.0), 1.0)


@dataclass(frozen=True)
class VanishingPoint:
    """The point (homogeneous px, unit norm) where the `inliers` of the segments meet, their weighted RMS angle to it
    and the share of the segments' weight they hold."""

    point_h: np.ndarray
    inliers: np.ndarray
    rms_deg: float
    support: float

    @property
    def at_infinity(self) -> bool:
        return abs(self.point_h[2]) < 1e-12 * np.linalg.norm(self.point_h[:2])

    @property
    def point_px(self) -> np.ndarray:
        """The point in pixels; infinite where the segments are parallel."""
        return np.full(2, np.inf) if self.at_infinity else self.point_h[:2] / self.point_h[2]


def _in_unit_frame(segments: Segments) -> tuple[np.ndarray, Segments]:
    """The similarity (3x3) taking the segments' points' centre to 0 and their spread to about 1 (for conditioning),
    and the segments in that frame."""
    centre = segments.points_px.mean(axis=0)
    spread = max(float(np.sqrt(((segments.points_px - centre) ** 2).sum(axis=1).mean())), 1e-9)
    to_unit = np.array([[1 / spread, 0, -centre[0] / spread], [0, 1 / spread, -centre[1] / spread], [0, 0, 1]])
    return to_unit, Segments((segments.points_px - centre) / spread, segments.directions, segments.weights)


def _lines(segments: Segments) -> np.ndarray:
    """Each segment's line (N, 3): a·x + b·y + c = 0 with (a, b) its unit normal."""
    normals = np.column_stack([-segments.directions[:, 1], segments.directions[:, 0]])
    return np.column_stack([normals, -(normals * segments.points_px).sum(axis=1)])


def _refine(segments: Segments, point_h: np.ndarray) -> np.ndarray:
    """The point minimising the weighted sum of the segments' squared sines to it (reweighted least squares of
    the lines' algebraic distances, each divided by the segment's distance to the point)."""
    lines = _lines(segments)
    point = point_h / np.linalg.norm(point_h)
    for _ in range(REFINE_ITERATIONS):
        towards = np.linalg.norm(point[None, :2] - point[2] * segments.points_px, axis=1)
        weights = segments.weights / np.maximum(towards, 1e-12) ** 2
        scatter = (lines * weights[:, None]).T @ lines
        _, vectors = np.linalg.eigh(scatter)
        candidate = vectors[:, 0]
        point = candidate if candidate @ point >= 0 else -candidate
    return point


def refine_point(segments: Segments, point_h: np.ndarray) -> np.ndarray:
    """The homogeneous point (px, unit norm) minimising the segments' weighted squared sines to it, from `point_h`."""
    to_unit, unit = _in_unit_frame(segments)
    refined = np.linalg.inv(to_unit) @ _refine(unit, to_unit @ np.asarray(point_h, dtype=float))
    return refined / np.linalg.norm(refined)


def find_vanishing_point(segments: Segments, max_angle_deg: float, min_support: float, iterations: int = 1000,
                         seed: int = 0) -> VanishingPoint | FailedEstimate:
    """The point most of the segments' weight points at, within `max_angle_deg` each; a `FailedEstimate` when
    fewer than two segments, or less than `min_support` of their weight, agree on one."""
    if len(segments) < 2 or not np.any(segments.weights > 0):
        return FailedEstimate(f"{len(segments)} segment(s): too few to meet anywhere")
    to_unit, unit = _in_unit_frame(segments)
    lines = _lines(unit)
    rng = np.random.default_rng(seed)
    probability = unit.weights / unit.weights.sum()
    limit = np.sin(np.radians(max_angle_deg))
    best, best_score = None, -1.0
    for _ in range(iterations):
        i, j = rng.choice(len(unit), size=2, replace=False, p=probability)
        point = np.cross(lines[i], lines[j])
        if not np.any(point):
            continue
        score = float(unit.weights[unit.sin_to(point) < limit].sum())
        if score > best_score:
            best, best_score = point, score
    if best is None:
        return FailedEstimate("the segments are all one line")
    for _ in range(3):
        inliers = unit.sin_to(best) < limit
        best = _refine(unit.subset(inliers), best)
    inliers = unit.sin_to(best) < limit
    support = float(unit.weights[inliers].sum() / unit.weights.sum())
    if support < min_support or inliers.sum() < 2:
        return FailedEstimate(f"the segments agree on no point: at most {support:.0%} of their weight within "
                              f"{max_angle_deg:g} deg of one")
    sines = unit.sin_to(best)[inliers]
    rms_deg = float(np.degrees(np.arcsin(np.sqrt(np.average(sines ** 2, weights=unit.weights[inliers])))))
    point_h = np.linalg.inv(to_unit) @ best
    return VanishingPoint(point_h / np.linalg.norm(point_h), inliers, rms_deg, support)
