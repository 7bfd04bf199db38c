"""Turning vehicle ROI crops (BGR uint8 arrays, as OpenCV reads them) into the classifier's input."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from vehloc.errors import VehlocError

MIN_SIDE_PX = 8


class ImageInputError(VehlocError):
    """An input is not a usable colour image."""


def load_bgr(image: np.ndarray | str | Path, name: str = "image") -> np.ndarray:
    """A BGR uint8 (H, W, 3) array from an array or an image path; ImageInputError otherwise."""
    if isinstance(image, (str, Path)):
        path = Path(image)
        if not path.is_file():
            raise ImageInputError(f"{path}: image does not exist")
        array = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if array is None:
            raise ImageInputError(f"{path}: not a readable image")
        name = str(path)
        if array.ndim == 3 and array.shape[2] == 4:
            array = array[:, :, :3]
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


def to_input(bgr: np.ndarray, resize_px: int, input_size_px: int) -> np.ndarray:
    """Resize to a `resize_px` square, centre-crop `input_size_px`, RGB float32 in [0, 1], (3, S, S)."""
    height_px, width_px = bgr.shape[:2]
    shrinking = resize_px < min(height_px, width_px)
    square = cv2.resize(bgr, (resize_px, resize_px), interpolation=cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR)
    offset = int(round((resize_px - input_size_px) / 2.0))  # as torchvision CenterCrop
    crop = square[offset:offset + input_size_px, offset:offset + input_size_px]
    rgb = cv2.cvtColor(crop, cv2.COLOR_BGR2RGB)
    return np.ascontiguousarray(rgb.transpose(2, 0, 1), dtype=np.float32) / 255.0
