"""The straight edges of a vehicle body in its ROI: colour clusters, Canny, probabilistic Hough.

Blob and cluster analysis first take the high-frequency content out of the body's colour regions
(paper, Sec. II-E): the masked pixels are clustered by colour (k-means in Lab), small blobs of a
cluster are absorbed by their surroundings (a majority filter over the cluster labels), and every
pixel is replaced by its cluster's colour, the background by one colour of its own. Canny then finds
only the boundaries between clusters and the silhouette, and `cv2.HoughLinesP` their straight parts, each then
moved onto its edge's sub-pixel position in the frame (`vehloc.geometry.subpixel_lines`).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_range
from vehloc.geometry.subpixel_lines import refined_segments_px


@dataclass(frozen=True)
class BodyLineParams:
    """Colour clustering, Canny and Hough settings of the body-edge extraction (the `lines` section of
    `conf/localize/footprint/default.yaml`)."""

    clusters: int
    cluster_sample_px: int
    cluster_iterations: int
    majority_window_px: int
    canny_low: float
    canny_high: float
    hough_angle_step_deg: float
    hough_votes: int
    min_length_fraction: float
    min_length_px: float
    max_gap_px: int
    refine_reach_px: float

    def __post_init__(self) -> None:
        for name in ("clusters", "cluster_sample_px", "cluster_iterations", "majority_window_px", "hough_votes"):
            check_range(name, getattr(self, name), 1)
        check_range("canny_low", self.canny_low, 0.0)
        check_range("canny_high", self.canny_high, self.canny_low)
        check_range("hough_angle_step_deg", self.hough_angle_step_deg, 0.0, 90.0, low_open=True)
        check_range("min_length_fraction", self.min_length_fraction, 0.0, 1.0)
        check_range("min_length_px", self.min_length_px, 0.0)
        check_range("max_gap_px", self.max_gap_px, 0)
        check_range("refine_reach_px", self.refine_reach_px, 0.0)


def kmeans_centres(samples: np.ndarray, clusters: int, iterations: int) -> np.ndarray:
    """Cluster centres (K, D) of samples (N, D): farthest-point seeding from the median, then Lloyd
    iterations; deterministic, so a detector gives the same answer on the same image."""
    centres = [np.median(samples, axis=0)]
    distance = np.sum((samples - centres[0]) ** 2, axis=1)
    for _ in range(1, min(clusters, len(samples))):
        centres.append(samples[int(np.argmax(distance))])
        distance = np.minimum(distance, np.sum((samples - centres[-1]) ** 2, axis=1))
    centres = np.array(centres)
    for _ in range(iterations):
        labels = nearest_centre(samples, centres)
        for k in range(len(centres)):
            members = samples[labels == k]
            if len(members):
                centres[k] = members.mean(axis=0)
    return centres


def nearest_centre(samples: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Index (N,) of the nearest centre of every sample."""
    return np.argmin(((samples[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2), axis=1)


def colour_clusters(roi_bgr: np.ndarray, mask: np.ndarray, params: BodyLineParams) -> np.ndarray:
    """The ROI painted with its clusters' colours (uint8, OpenCV's 8-bit Lab) after the majority filter over the
    cluster labels; the background in its median colour."""
    lab = cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2LAB)
    inside = lab[mask].astype(np.float32)
    stride = max(1, len(inside) // params.cluster_sample_px)
    centres = kmeans_centres(inside[::stride], params.clusters, params.cluster_iterations)
    labels = np.full(mask.shape, len(centres), np.int32)
    labels[mask] = nearest_centre(inside, centres)
    window = (params.majority_window_px, params.majority_window_px)
    votes = np.stack([cv2.boxFilter((labels == k).astype(np.float32), -1, window, normalize=False)
                      for k in range(len(centres) + 1)])
    labels = np.where(mask, np.argmax(votes[:-1], axis=0), len(centres))
    background = np.median(lab[~mask], axis=0) if (~mask).any() else np.zeros(3)
    palette = np.vstack([centres, background]).round().clip(0, 255).astype(np.uint8)
    return palette[labels]


def body_segments_px(
    roi_bgr: np.ndarray, mask: np.ndarray, offset_px: np.ndarray, params: BodyLineParams
) -> np.ndarray:
    """Straight edge segments (N, 4) `x1 y1 x2 y2` of the body in frame px: Canny on the colour
    clusters, then `cv2.HoughLinesP`, each segment moved onto its edge's sub-pixel position in `roi_bgr` within
    `params.refine_reach_px` (0: as Hough gives it); only edges on or inside the silhouette count."""
    painted = colour_clusters(roi_bgr, mask, params)
    edges = cv2.Canny(painted, params.canny_low, params.canny_high)
    edges[~cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)] = 0
    min_length_px = max(params.min_length_px, params.min_length_fraction * float(np.hypot(*mask.shape)))
    segments = cv2.HoughLinesP(
        edges, 1, np.radians(params.hough_angle_step_deg), params.hough_votes,
        minLineLength=min_length_px, maxLineGap=params.max_gap_px,
    )
    if segments is None:
        return np.zeros((0, 4))
    offset = np.tile(np.asarray(offset_px, dtype=float), 2)
    return refined_segments_px(roi_bgr, segments.reshape(-1, 4).astype(float), params.refine_reach_px) + offset
