"""Vehicle ROI crops and the train/eval image transforms (RGB float tensors in [0, 1])."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torchvision.transforms import v2


def enlarge_box_xyxy_px(
    box_xyxy_px: Sequence[int], enlarge_fraction: float, width_px: int, height_px: int
) -> tuple[int, int, int, int]:
    """Grow a 0-based half-open box by `enlarge_fraction` of its size on each side, clipped to the image."""
    x0, y0, x1, y1 = box_xyxy_px
    pad_x = round((x1 - x0) * enlarge_fraction)
    pad_y = round((y1 - y0) * enlarge_fraction)
    return max(0, x0 - pad_x), max(0, y0 - pad_y), min(width_px, x1 + pad_x), min(height_px, y1 + pad_y)


def enlarged_roi(image: np.ndarray, box_xyxy_px: Sequence[int], enlarge_fraction: float) -> np.ndarray:
    """The part of `image` under a 0-based half-open box grown by `enlarge_fraction` on each side;
    ValueError if the box lies outside the image."""
    height_px, width_px = image.shape[:2]
    x0, y0, x1, y1 = enlarge_box_xyxy_px(box_xyxy_px, enlarge_fraction, width_px, height_px)
    if x1 <= x0 or y1 <= y0:
        raise ValueError(f"box {tuple(box_xyxy_px)} lies outside the {width_px}x{height_px} image")
    return image[y0:y1, x0:x1]


def train_transform(
    input_size_px: int,
    crop_scale: Sequence[float] = (0.6, 1.0),
    crop_ratio: Sequence[float] = (0.75, 1.333),
    hflip: bool = True,
    color_jitter: float = 0.2,
) -> v2.Compose:
    """Random resized crop, horizontal flip and colour jitter of a uint8 image tensor, to float [0, 1]."""
    steps: list[torch.nn.Module] = [
        v2.RandomResizedCrop(input_size_px, scale=tuple(crop_scale), ratio=tuple(crop_ratio), antialias=True)
    ]
    if hflip:
        steps.append(v2.RandomHorizontalFlip())
    if color_jitter > 0:
        steps.append(v2.ColorJitter(color_jitter, color_jitter, color_jitter))
    steps.append(v2.ToDtype(torch.float32, scale=True))
    return v2.Compose(steps)


def eval_transform(input_size_px: int, resize_px: int | None = None) -> v2.Compose:
    """Resize the ROI to a `resize_px` square (default: the input size), centre-crop, to float [0, 1]."""
    resize_px = resize_px or input_size_px
    if resize_px < input_size_px:
        raise ValueError(f"eval resize {resize_px} px is smaller than the input size {input_size_px} px")
    return v2.Compose([
        v2.Resize((resize_px, resize_px), antialias=True),
        v2.CenterCrop(input_size_px),
        v2.ToDtype(torch.float32, scale=True),
    ])
