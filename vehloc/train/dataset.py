"""A torch Dataset of CompCars samples: decoded image, enlarged ROI crop, transform, class index."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import torch
from torch.utils.data import Dataset

from vehloc.data.compcars import CompCarsSample
from vehloc.data.preprocess import ImageInputError, enlarged_roi, read_bgr
from vehloc.errors import DataError


def load_roi(sample: CompCarsSample, enlarge_fraction: float) -> np.ndarray:
    """The sample's labelled box, enlarged on each side, as a BGR uint8 (H, W, 3) array."""
    try:
        image = read_bgr(sample.image_path)
        return enlarged_roi(image, sample.box, enlarge_fraction)
    except ImageInputError as err:
        raise DataError(str(err)) from None
    except ValueError as err:
        raise DataError(f"{sample.label_path}: {err}") from None


class CompCarsCrops(Dataset):
    """(image tensor, class index, sample index) for each sample of a split."""

    def __init__(
        self,
        samples: Sequence[CompCarsSample],
        labels: Sequence[int],
        transform: Callable[[np.ndarray], torch.Tensor],
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
