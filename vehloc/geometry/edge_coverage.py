"""How much of each pixel along a vehicle's outline the vehicle covers, from the colours the edge mixes.

A camera (and an anti-aliased drawing) gives an outline pixel a mix of the vehicle's colour and the road's in
proportion to how much of it each covers. The silhouette's threshold turns that mix into in or out, which moves the
outline by up to half a pixel, outwards where the vehicle contrasts strongly with the road and inwards where it does
not; at 30 m and more that is a good part of the fit's error. Near the outline the coverage is read back instead:
the frame's change from the background projected on the change the vehicle's nearest inner colour makes
(`edge_coverage`)."""

from __future__ import annotations

import cv2
import numpy as np

MIN_INNER_PX = 1
"""The inner pixels whose colour stands for the vehicle's lie this much deeper than the outline's band."""
MIX_SLACK = 0.25
"""A pixel is a mix of the road's colour and the vehicle's inner one when its change from the road, along the inner
one's, is within this share of it beyond 0 and 1, and off that line by at most this share (else another part of the
vehicle, a window beside the body's colour, or sensor noise on a faint change: its weight is left as it was)."""


def band_and_inner(mask: np.ndarray, band_px: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """The pixels within `band_px` of the outline of `mask` (inside and out), as rows and columns, and for each the
    nearest pixel `MIN_INNER_PX` deeper inside than the band (rows and columns); None when `mask` has no such inside."""
    vehicle = mask.astype(np.uint8)
    band_kernel = np.ones((2 * band_px + 1,) * 2, np.uint8)
    inner_reach = band_px + MIN_INNER_PX
    inner = cv2.erode(vehicle, np.ones((2 * inner_reach + 1,) * 2, np.uint8))
    if not inner.any():
        return None
    band = (cv2.dilate(vehicle, band_kernel) > 0) & ~(cv2.erode(vehicle, band_kernel) > 0)
    _, labels = cv2.distanceTransformWithLabels(1 - inner, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    rows, cols = np.nonzero(inner)  # the labels number the inner pixels in this (row-major) order
    nearest_row, nearest_col = np.zeros(labels.max() + 1, np.intp), np.zeros(labels.max() + 1, np.intp)
    nearest_row[labels[rows, cols]], nearest_col[labels[rows, cols]] = rows, cols
    band_rows, band_cols = np.nonzero(band)
    return (band_rows, band_cols, nearest_row[labels[band_rows, band_cols]],
            nearest_col[labels[band_rows, band_cols]])


def edge_coverage(frame_bgr: np.ndarray, background_bgr: np.ndarray, mask: np.ndarray, doubtful: np.ndarray,
                  band_px: int, min_contrast: float) -> tuple[np.ndarray, np.ndarray]:
    """The vehicle's share of each pixel within `band_px` of the outline of `mask` (inside and out), and where it is
    read: the frame's change from the background along the change of the nearest pixel deeper inside, clipped to
    [0, 1], where that inner pixel differs from the background by more than `min_contrast` (grey levels, its colour's
    distance), neither it nor the pixel is `doubtful` (maybe shadow: its mix is not the vehicle's and the road's), and
    the pixel's colour is such a mix (`MIX_SLACK`)."""
    share, known = np.zeros(mask.shape, np.float32), np.zeros(mask.shape, bool)
    pairs = band_and_inner(mask, band_px)
    if pairs is None:
        return share, known
    band_rows, band_cols, inner_row, inner_col = pairs  # only the band's pixels are read
    background = background_bgr[band_rows, band_cols].astype(np.float32)
    change = frame_bgr[band_rows, band_cols].astype(np.float32) - background
    vehicle_change = frame_bgr[inner_row, inner_col].astype(np.float32) - background
    contrast_sq = (vehicle_change * vehicle_change).sum(axis=1)
    mixed = (change * vehicle_change).sum(axis=1) / np.maximum(contrast_sq, 1e-6)
    off_mix = change - mixed[:, None] * vehicle_change
    readable = ((contrast_sq > min_contrast ** 2) & ~doubtful[band_rows, band_cols] & ~doubtful[inner_row, inner_col]
                & (mixed > -MIX_SLACK) & (mixed < 1.0 + MIX_SLACK)
                & ((off_mix * off_mix).sum(axis=1) < (MIX_SLACK ** 2) * contrast_sq))
    known[band_rows[readable], band_cols[readable]] = True
    share[band_rows[readable], band_cols[readable]] = np.clip(mixed[readable], 0.0, 1.0)
    return share, known
