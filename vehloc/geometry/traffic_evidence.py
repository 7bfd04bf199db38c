"""What moving vehicles show of the road's directions, frame by frame: the straight paths of points tracked on them
(KLT features, forward-backward checked: each a segment towards the traffic's vanishing point) and the straight
edges of their bodies (line segments, many across the road: towards the second vanishing point); and the road's own
lines along the traffic, where it has them, once the traffic has told their direction."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.geometry.roi import Silhouette
from vehloc.geometry.vanishing import Segments

LK_WINDOW_PX = 15
LK_LEVELS = 2


@dataclass(frozen=True)
class FeatureParams:
    """How points are tracked on the vehicles and which of their paths count as straight segments."""

    max_features: int
    min_distance_px: float
    max_backward_error_px: float
    min_track_frames: int
    min_track_extent_px: float
    max_track_rms_px: float


class FeatureTracks:
    """Points tracked from frame to frame inside the moving vehicles' mask; each path, once lost, a segment if
    it is long and straight enough (and its points, one a frame, kept in `straight_paths`)."""

    def __init__(self, params: FeatureParams) -> None:
        self.params = params
        self.previous: np.ndarray | None = None
        self.points = np.zeros((0, 2), np.float32)
        self.paths: list[list[np.ndarray]] = []
        self.segments: list[tuple[np.ndarray, np.ndarray, float]] = []
        self.straight_paths: list[np.ndarray] = []

    def update(self, gray: np.ndarray, moving_mask: np.ndarray, detect: bool) -> None:
        """Follow the points into `gray`, end the paths of those lost or off the mask, and (`detect`) start new ones
        on the mask's corners."""
        if self.previous is not None and len(self.points):
            kept = self._follow(gray, moving_mask)
            self.paths = [path for path, keep in zip(self.paths, kept) if keep]
        if detect:
            self._detect(gray, moving_mask)
        self.previous = gray

    def _follow(self, gray: np.ndarray, moving_mask: np.ndarray) -> np.ndarray:
        lk = {"winSize": (LK_WINDOW_PX, LK_WINDOW_PX), "maxLevel": LK_LEVELS}
        forward, status, _ = cv2.calcOpticalFlowPyrLK(self.previous, gray, self.points, None, **lk)
        backward, back_status, _ = cv2.calcOpticalFlowPyrLK(gray, self.previous, forward, None, **lk)
        height, width = gray.shape
        inside = (forward[:, 0] >= 0) & (forward[:, 1] >= 0) & (forward[:, 0] <= width - 1) & (forward[:, 1] <= height - 1)
        kept = ((status[:, 0] == 1) & (back_status[:, 0] == 1) & inside
                & (np.linalg.norm(backward - self.points, axis=1) < self.params.max_backward_error_px))
        columns = np.clip(np.round(forward[:, 0]).astype(int), 0, width - 1)
        rows = np.clip(np.round(forward[:, 1]).astype(int), 0, height - 1)
        kept &= moving_mask[rows, columns] > 0
        for path, point, keep in zip(self.paths, forward, kept):
            if keep:
                path.append(point.astype(float))
            else:
                self._end(path)
        self.points = forward[kept].reshape(-1, 2)
        return kept

    def _detect(self, gray: np.ndarray, moving_mask: np.ndarray) -> None:
        free = moving_mask.copy()
        for x, y in self.points:
            cv2.circle(free, (int(x), int(y)), int(self.params.min_distance_px), 0, -1)
        corners = cv2.goodFeaturesToTrack(gray, self.params.max_features, 0.01, self.params.min_distance_px, mask=free)
        if corners is None:
            return
        corners = corners.reshape(-1, 2).astype(np.float32)
        self.points = np.vstack([self.points, corners]).astype(np.float32)
        self.paths += [[corner.astype(float)] for corner in corners]

    def _end(self, path: list[np.ndarray]) -> None:
        """Keep an ended path as a segment (its mean point, principal direction, extent) when straight."""
        if len(path) < self.params.min_track_frames:
            return
        points = np.array(path)
        extent = float(np.linalg.norm(points[-1] - points[0]))
        if extent < self.params.min_track_extent_px:
            return
        centre = points.mean(axis=0)
        _, singular, axes = np.linalg.svd(points - centre, full_matrices=False)
        if singular[1] / np.sqrt(len(points)) <= self.params.max_track_rms_px:
            self.segments.append((centre, axes[0], extent))
            self.straight_paths.append(points)

    def finish(self) -> Segments:
        """End every path still followed; all the straight paths as segments, weighted by their extent."""
        for path in self.paths:
            self._end(path)
        self.paths, self.points = [], np.zeros((0, 2), np.float32)
        if not self.segments:
            return Segments.empty()
        centres, directions, extents = zip(*self.segments)
        return Segments(np.array(centres), np.array(directions), np.array(extents))


def edge_segments(gray: np.ndarray, mask: np.ndarray | None, min_length_px: float) -> Segments:
    """The straight edges (OpenCV's line segment detector) at least `min_length_px` long, weighted by their length;
    with `mask`, those whose middle lies on it (the moving vehicles)."""
    found = cv2.createLineSegmentDetector().detect(gray)[0]
    if found is None:
        return Segments.empty()
    ends = found.reshape(-1, 4).astype(float)
    middles = (ends[:, :2] + ends[:, 2:]) / 2
    vectors = ends[:, 2:] - ends[:, :2]
    lengths = np.linalg.norm(vectors, axis=1)
    keep = lengths >= min_length_px
    if mask is not None:
        height, width = gray.shape
        columns = np.clip(middles[:, 0].astype(int), 0, width - 1)
        rows = np.clip(middles[:, 1].astype(int), 0, height - 1)
        keep &= mask[rows, columns] > 0
    return Segments(middles[keep], vectors[keep] / lengths[keep, None], lengths[keep])


def road_line_candidates(background_bgr: np.ndarray, vp1_h: np.ndarray, min_length_fraction: float,
                         max_angle_deg: float) -> Segments:
    """The road's own lines along the traffic (lane lines, edges, kerbs) in the image without traffic: its long
    straight edges (at least `min_length_fraction` of the image's diagonal) within `max_angle_deg` of the first
    vanishing point that the traffic's motion gave."""
    gray = cv2.cvtColor(background_bgr, cv2.COLOR_BGR2GRAY)
    edges = edge_segments(gray, None, min_length_fraction * float(np.hypot(*gray.shape)))
    return edges.subset(edges.sin_to(vp1_h) < np.sin(np.radians(max_angle_deg)))


def across_candidates(edges: Segments, vp1_h: np.ndarray, min_angle_to_vp1_deg: float,
                      max_angle_from_horizontal_deg: float) -> Segments:
    """The edges that may run across the road: not towards the first vanishing point and not steep (the vertical
    edges of the bodies, towards the third)."""
    away = edges.sin_to(vp1_h) > np.sin(np.radians(min_angle_to_vp1_deg))
    flat = np.abs(edges.directions[:, 1]) < np.sin(np.radians(max_angle_from_horizontal_deg))
    return edges.subset(away & flat)


@dataclass(frozen=True)
class Outline:
    """A vehicle's extremes in one frame (pixel centres): its top row, left and right columns, and its bottom row."""

    sides_px: np.ndarray
    bottom_px: float

    @property
    def height_px(self) -> float:
        return self.bottom_px - float(self.sides_px[0]) + 1.0


def sure_outline(silhouette: Silhouette, roi: Box, inset_px: float) -> Outline | None:
    """The extremes of the silhouette's sure pixels (not doubtful, or solid: no cast shadow) in frame pixels, each moved
    `inset_px` in (a pixel the vehicle covers in part is changed too); None when it has none."""
    sure = silhouette.mask & (~silhouette.doubtful | silhouette.solid)
    rows, columns = np.nonzero(sure)
    if len(rows) == 0:
        return None
    return Outline(np.array([roi.y0 + rows.min() + inset_px, roi.x0 + columns.min() + inset_px,
                             roi.x0 + columns.max() - inset_px]), float(roi.y0 + rows.max() - inset_px))
