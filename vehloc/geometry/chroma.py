"""How far a pixel's colour moved from the road's, as shadow keeps it or a coloured body changes it.

A shadow darkens the road and keeps its chromaticity (each of b, g, r over their sum); a coloured body changes it.
Video codecs store colour (Cb, Cr) at half the resolution of brightness, so beside a saturated vehicle its colour
bleeds about a pixel into its own shadow, which then reads as coloured. `chromaticity_shift` measures the change,
and within `bleed_px` of a pixel whose colour changed (`colour_change`) takes the least change in that reach.
`chroma` says how far a pixel's own colour lies from grey (a wheel's rim is grey, a lit lamp is not)."""

from __future__ import annotations

import cv2
import numpy as np

CHROMA_FROM_BGR = np.array([[0.5, -0.331264, -0.168736],   # Cb (BT.601, as JPEG and MPEG store it)
                            [-0.081312, -0.418688, 0.5]],  # Cr
                           np.float32)
"""The colour-difference rows of the video's colour space, from b, g, r."""


def chroma(frame_bgr: np.ndarray) -> np.ndarray:
    """How far each pixel's colour lies from grey: the larger of its Cb and Cr, in grey levels (float32)."""
    return np.abs(frame_bgr.astype(np.float32) @ CHROMA_FROM_BGR.T).max(axis=2)


def colour_change(frame_bgr: np.ndarray, background_bgr: np.ndarray) -> np.ndarray:
    """The larger of the Cb and Cr changes from the background, in grey levels (float32)."""
    change = frame_bgr.astype(np.float32) - background_bgr.astype(np.float32)
    return np.abs(change @ CHROMA_FROM_BGR.T).max(axis=2)


def chromaticity_shift(frame_bgr: np.ndarray, background_bgr: np.ndarray, bleed_px: int = 0,
                       bleed_min_change: float = 0.0) -> np.ndarray:
    """The largest change of b, g or r over their sum (plus 1) from the background's (float32); with `bleed_px`,
    where a pixel within `bleed_px` changed its colour by more than `bleed_min_change` grey levels (Cb or Cr), the
    least change within `bleed_px` instead: that colour may have bled in at half resolution."""
    frame, background = frame_bgr.astype(np.float32), background_bgr.astype(np.float32)
    shift = np.abs(frame / (frame.sum(axis=2, keepdims=True) + 1.0)
                   - background / (background.sum(axis=2, keepdims=True) + 1.0)).max(axis=2)
    if not bleed_px:
        return shift
    reach = np.ones((2 * bleed_px + 1,) * 2, np.uint8)
    coloured_near = cv2.dilate(colour_change(frame, background), reach) > bleed_min_change
    return np.where(coloured_near, cv2.erode(shift, reach), shift)
