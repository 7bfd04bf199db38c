"""The outline of a foreground mask in continuous pixel coordinates, for tangents to a vehicle's silhouette.

A mask pixel is the unit square around its centre; a pixel that is half covered or more is in the mask,
so the true outline runs, on average, along the outer sides of the boundary pixels. `outline_corners_px`
returns those sides' corners, offset into the frame."""

from __future__ import annotations

import cv2
import numpy as np

PIXEL_CORNERS = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])


def outline_corners_px(mask: np.ndarray, offset_px: np.ndarray) -> np.ndarray:
    """Corners (N, 2) of the squares of every pixel on the outer boundary of the mask's blobs, in frame px."""
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return np.zeros((0, 2))
    centres = np.unique(np.concatenate([c.reshape(-1, 2) for c in contours]), axis=0).astype(float)
    return (centres[:, None, :] + PIXEL_CORNERS[None]).reshape(-1, 2) + np.asarray(offset_px, dtype=float)

