"""A classifier that always names the true model: the catalog's classes, dimensions and shapes, and one-hot
probabilities of the case's model. With it the benchmark measures the geometry alone, apart from the
classifier."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.preprocess import Preprocessing
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.metadata import ModelMetadata
from vehloc.synth.body import catalog_shapes
from vehloc.synth.catalog import vehicle_specs


def catalog_metadata() -> ModelMetadata:
    """The metadata an exported classifier of the whole catalog would carry (its classes, sizes and shapes)."""
    classes = tuple(sorted(vehicle_specs(), key=lambda spec: spec.model_id))
    preprocessing = Preprocessing(32, 32, 0.1, (0.5, 0.5, 0.5), (0.25, 0.25, 0.25))
    return ModelMetadata(classes, preprocessing, "true model", "0" * 64, shapes=catalog_shapes())


class TrueModelClassifier(VehicleClassifier):
    """Every crop is `model_id` with probability 1."""

    def __init__(self, model_id: int, metadata: ModelMetadata | None = None) -> None:
        super().__init__(None, metadata or catalog_metadata(), "the true model")
        self.index = [c.model_id for c in self.classes].index(model_id)

    def probabilities(self, images: Sequence[np.ndarray | str | Path], boxes: Sequence[Box] | None = None,
                      batch_size: int = 32) -> np.ndarray:
        one_hot = np.zeros((len(images), len(self.classes)))
        one_hot[:, self.index] = 1.0
        return one_hot
