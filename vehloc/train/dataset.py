"""A torch Dataset of CompCars samples: decoded image, enlarged ROI crop, transform, class index."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import cv2
import torch
from torch.utils.data import Dataset

from vehloc.data.compcars import CompCarsSample
from vehloc.errors import DataError
from vehloc.train.transforms import enlarged_roi


def load_roi(sample: CompCarsSample, enlarge_fraction: float) -> torch.Tensor:
    """The sample's labelled box, enlarged on each side, as a uint8 (3, H, W) RGB tensor."""
    bgr = cv2.imread(str(sample.image_path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise DataError(f"{sample.image_path}: not a readable image")
    try:
        roi = enlarged_roi(bgr, sample.crop_box_xyxy_px(), enlarge_fraction)
    except ValueError as err:
        raise DataError(f"{sample.label_path}: {err}") from None
    rgb = cv2.cvtColor(roi, cv2.COLOR_BGR2RGB)
    return torch.from_numpy(rgb).permute(2, 0, 1).contiguous()


class CompCarsCrops(Dataset):
    """(image tensor, class index, sample index) for each sample of a split."""

    def __init__(
        self,
        samples: Sequence[CompCarsSample],
        labels: Sequence[int],
        transform: Callable[[torch.Tensor], torch.Tensor],
        enlarge_fraction: float = 0.10,
    ) -> None:
        if len(samples) != len(labels):
            raise ValueError(f"{len(samples)} samples but {len(labels)} labels")
        self.samples = list(samples)
        self.labels = list(labels)
        self.transform = transform
        self.enlarge_fraction = enlarge_fraction

    def __len__(self) -> int:
        return len(self.samples)

    def __getitem__(self, index: int) -> tuple[torch.Tensor, int, int]:
        roi = load_roi(self.samples[index], self.enlarge_fraction)
        return self.transform(roi), self.labels[index], index
