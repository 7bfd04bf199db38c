"""An exported classifier run over labelled images (a split of a CompCars-format set): class probabilities and
the true class of each, in batches so that a large split never sits in memory at once."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from vehloc.data.compcars import CompCarsSample
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.metadata import ModelFileError

CHUNK_IMAGES = 256
"""Images read and preprocessed at a time."""


@dataclass(frozen=True)
class LabelledPredictions:
    """(N, C) class probabilities of N labelled images, their (N,) true class indices and names."""

    probabilities: np.ndarray
    targets: np.ndarray
    images: tuple[str, ...]

    @property
    def top1_pct(self) -> float:
        """Top-1 accuracy in percent (0 for no images)."""
        if not len(self.targets):
            return 0.0
        return 100.0 * float(np.mean(self.probabilities.argmax(axis=1) == self.targets))

    def top1_agreement(self, other: LabelledPredictions) -> float:
        """The share of images on which both give the same top-1 class."""
        return float(np.mean(self.probabilities.argmax(axis=1) == other.probabilities.argmax(axis=1)))


def class_indices(classifier: VehicleClassifier, samples: Sequence[CompCarsSample]) -> np.ndarray:
    """The classifier's class index of each sample's model; ModelFileError naming the first model it lacks."""
    index = {spec.model_id: i for i, spec in enumerate(classifier.classes)}
    missing = sorted({s.model_id for s in samples} - set(index))
    if missing:
        raise ModelFileError(
            f"{classifier.source}: has no class for model id(s) {', '.join(map(str, missing[:10]))} of the images")
    return np.array([index[s.model_id] for s in samples], dtype=np.int64)


def predict_labelled(classifier: VehicleClassifier, samples: Sequence[CompCarsSample], batch_size: int = 32,
                     progress: str | None = None) -> LabelledPredictions:
    """The class probabilities of each sample's vehicle ROI (its box, enlarged as in training), with a progress
    bar named `progress` when given."""
    targets = class_indices(classifier, samples)
    starts = range(0, len(samples), CHUNK_IMAGES)
    chunks = []
    for start in tqdm(starts, desc=progress, unit="chunk", disable=progress is None):
        chunk = samples[start:start + CHUNK_IMAGES]
        chunks.append(classifier.probabilities([s.image_path for s in chunk], [s.box for s in chunk], batch_size))
    probabilities = np.concatenate(chunks) if chunks else np.zeros((0, len(classifier.classes)), np.float32)
    return LabelledPredictions(probabilities, targets, tuple(s.rel_path for s in samples))
