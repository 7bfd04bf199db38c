"""Checking the images handed to the onnxruntime classifier: BGR uint8 arrays, as OpenCV reads them, or
image paths read by the one reader of `vehloc.data.preprocess`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vehloc.data.preprocess import ImageInputError, read_bgr

MIN_SIDE_PX = 8

__all__ = ["ImageInputError", "load_bgr"]


def load_bgr(image: np.ndarray | str | Path, name: str = "image") -> np.ndarray:
    """A BGR uint8 (H, W, 3) array from an array or an image path; ImageInputError otherwise."""
    if isinstance(image, (str, Path)):
        array, name = read_bgr(image), str(image)
    else:
        array = np.asarray(image)
    if array.ndim != 3 or array.shape[2] != 3:
        raise ImageInputError(f"{name}: expected a colour BGR image (H, W, 3), got shape {array.shape}")
    if min(array.shape[:2]) < MIN_SIDE_PX:
        raise ImageInputError(
            f"{name}: {array.shape[1]}x{array.shape[0]} px is too small to classify (at least {MIN_SIDE_PX} px a side)"
        )
    if array.dtype != np.uint8:
        raise ImageInputError(f"{name}: expected 8-bit pixels, got {array.dtype}")
    return array
