"""A straight edge segment moved onto its edge's sub-pixel position in the image.

`cv2.HoughLinesP` gives a segment through edge pixels' centres, its ends on whole pixels: an edge that slopes by
less than a pixel over its length comes out level. Seen end-on from afar, the lines across a vehicle's end slope by
a pixel or less over their 20-50 px, and a level image line there is several degrees off on the road. The frame
holds the sub-pixel position: a pixel the edge crosses has the two sides' colours mixed in proportion to the share
of it each covers, so across the edge the share of the first side's colour, summed along a profile from one side's
colour to the other's, is the distance to the edge. At every pixel along the segment the colour's profile across
it is sampled (bilinear, half a pixel apart) and the edge's position read so (where the two ends' colours differ
enough); a straight line fitted to those positions (least squares, the ones far off it dropped) is the refined
segment (`refined_segment_px`).
"""

from __future__ import annotations

import cv2
import numpy as np

STEP_PX = 0.5
"""The profile across the segment is sampled this far apart."""
END_MARGIN_PX = 2.0
"""Samples start and stop this far inside the segment's ends (the corners, where another edge meets it)."""
MIN_SAMPLES = 5
"""Fewer positions than this leave the segment as it was."""
MIN_CONTRAST = 12.0
"""A profile counts where its two ends' colours differ by at least this much (grey levels, their distance)."""
OUTLIER_PX = 0.3
"""Positions further than this (or 2.5 median deviations, if more) from the fitted line are dropped and it is fitted
again, at most `FIT_ROUNDS` times."""
FIT_ROUNDS = 3


def refined_segment_px(image_bgr: np.ndarray, segment_px: np.ndarray, reach_px: float) -> np.ndarray:
    """`segment_px` (`x1 y1 x2 y2`, px of `image_bgr`) moved onto its edge: the line through the edge's sub-pixel
    positions across it, read on profiles reaching `reach_px` either side, between the segment's ends' feet on it;
    the segment as it was where too few are read (under `MIN_SAMPLES`)."""
    start, end = np.asarray(segment_px[:2], float), np.asarray(segment_px[2:], float)
    length = float(np.linalg.norm(end - start))
    if length <= 2 * END_MARGIN_PX:
        return np.asarray(segment_px, float)
    along = (end - start) / length
    normal = np.array([-along[1], along[0]])
    at = np.arange(END_MARGIN_PX, length - END_MARGIN_PX + 1e-9, 1.0)
    across = np.arange(-reach_px, reach_px + 1e-9, STEP_PX)
    points = start + at[:, None, None] * along + across[None, :, None] * normal
    profiles = cv2.remap(np.ascontiguousarray(image_bgr, np.float32), points[..., 0].astype(np.float32),
                         points[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE).reshape(len(at), len(across), -1)
    first, second = profiles[:, :2].mean(axis=1), profiles[:, -2:].mean(axis=1)
    contrast = first - second
    contrast_sq = (contrast * contrast).sum(axis=1)
    share = ((profiles - second[:, None]) * contrast[:, None]).sum(axis=2) / np.maximum(contrast_sq, 1e-6)[:, None]
    share = np.clip(share, 0.0, 1.0)
    offset_px = across[0] + STEP_PX * (share.sum(axis=1) - (share[:, 0] + share[:, -1]) / 2)
    kept = contrast_sq >= MIN_CONTRAST ** 2
    if kept.sum() < MIN_SAMPLES:
        return np.asarray(segment_px, float)
    at, offset_px = at[kept], offset_px[kept]
    for _ in range(FIT_ROUNDS):
        design = np.stack([np.ones_like(at), at], axis=1)
        (intercept, slope), *_ = np.linalg.lstsq(design, offset_px, rcond=None)
        residual = np.abs(offset_px - design @ [intercept, slope])
        near = residual <= max(OUTLIER_PX, 2.5 * float(np.median(residual)))
        if near.all() or near.sum() < MIN_SAMPLES:
            break
        at, offset_px = at[near], offset_px[near]
    return np.concatenate([start + intercept * normal, end + (intercept + slope * length) * normal])


def refined_segments_px(image_bgr: np.ndarray, segments_px: np.ndarray, reach_px: float) -> np.ndarray:
    """Every segment (N, 4) of `image_bgr`'s px refined (`refined_segment_px`); as they were where `reach_px` is 0."""
    if reach_px <= 0 or len(segments_px) == 0:
        return np.asarray(segments_px, float)
    image = np.ascontiguousarray(image_bgr, np.float32)  # once for every segment (refined_segment_px keeps it so)
    return np.array([refined_segment_px(image, segment, reach_px) for segment in segments_px])
