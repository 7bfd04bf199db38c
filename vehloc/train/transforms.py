"""The train and eval image transforms of the data loaders: a BGR ROI (as OpenCV decodes it) in, an RGB
float tensor in [0, 1] out. Evaluation is the one preprocessing, `vehloc.data.preprocess.Preprocessing`;
training augments the ROI with torchvision."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
import torch
from torchvision.transforms import v2

from vehloc.data.preprocess import Preprocessing, padded_square


class TrainTransform:
    """Random resized crop, horizontal flip and colour jitter of a BGR ROI (first padded to a square when its
    aspect is kept, as in `Preprocessing.to_input`), to RGB float [0, 1]."""

    def __init__(
        self,
        input_size_px: int,
        keep_aspect: bool = False,
        crop_scale: Sequence[float] = (0.6, 1.0),
        crop_ratio: Sequence[float] = (0.75, 1.333),
        hflip: bool = True,
        color_jitter: float = 0.2,
    ) -> None:
        steps: list[torch.nn.Module] = [
            v2.RandomResizedCrop(input_size_px, scale=tuple(crop_scale), ratio=tuple(crop_ratio), antialias=True)
        ]
        if hflip:
            steps.append(v2.RandomHorizontalFlip())
        if color_jitter > 0:
            steps.append(v2.ColorJitter(color_jitter, color_jitter, color_jitter))
        steps.append(v2.ToDtype(torch.float32, scale=True))
        self.augment = v2.Compose(steps)
        self.keep_aspect = keep_aspect

    def __call__(self, roi_bgr: np.ndarray) -> torch.Tensor:
        if self.keep_aspect:
            roi_bgr = padded_square(roi_bgr)
        rgb = cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2RGB)
        return self.augment(torch.from_numpy(rgb).permute(2, 0, 1).contiguous())


class EvalTransform:
    """The one preprocessing of a BGR ROI, as a tensor."""

    def __init__(self, preprocessing: Preprocessing) -> None:
        self.preprocessing = preprocessing

    def __call__(self, roi_bgr: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(self.preprocessing.to_input(roi_bgr))
