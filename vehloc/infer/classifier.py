"""The onnxruntime vehicle classifier that everything downstream uses: ROI crops in, models and
dimensions out."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnxruntime as ort

from vehloc.data.dimension_error import expected_dims_mm
from vehloc.data.specs import VehicleSpec
from vehloc.infer.metadata import ModelFileError, ModelMetadata, read_metadata
from vehloc.infer.preprocess import load_bgr, to_input


@dataclass(frozen=True)
class Candidate:
    """One of the top-k models of a prediction."""

    model_id: int
    make: str
    model: str
    probability: float


@dataclass(frozen=True)
class Prediction:
    """The classifier's answer for one image."""

    top_k: tuple[Candidate, ...]
    top1_dims_mm: np.ndarray
    expected_dims_mm: np.ndarray

    @property
    def top1(self) -> Candidate:
        return self.top_k[0]


def default_providers() -> list[str]:
    """CUDA when onnxruntime has it, else the CPU."""
    available = ort.get_available_providers()
    return [p for p in ("CUDAExecutionProvider", "CPUExecutionProvider") if p in available]


class VehicleClassifier:
    """An exported vehloc classifier run by onnxruntime."""

    def __init__(self, session: ort.InferenceSession, metadata: ModelMetadata, source: str) -> None:
        self.session = session
        self.metadata = metadata
        self.source = source

    @classmethod
    def from_onnx(cls, path: str | Path, providers: Sequence[str] | None = None) -> VehicleClassifier:
        """Load a `.onnx` file written by vehloc-export; everything else is read from the file."""
        path = Path(path)
        if not path.is_file():
            raise ModelFileError(f"{path}: model file does not exist")
        try:
            session = ort.InferenceSession(str(path), providers=list(providers or default_providers()))
        except Exception as exc:  # onnxruntime raises its own exception types for corrupt files
            raise ModelFileError(f"{path}: not a loadable ONNX model ({str(exc).splitlines()[0]})") from None
        metadata = read_metadata(session.get_modelmeta().custom_metadata_map, str(path))
        return cls(session, metadata, str(path))

    @property
    def classes(self) -> tuple[VehicleSpec, ...]:
        return self.metadata.classes

    def probabilities(self, images: Sequence[np.ndarray | str | Path], batch_size: int = 32) -> np.ndarray:
        """(N, C) class probabilities of BGR crops or image paths."""
        meta = self.metadata
        inputs = [to_input(load_bgr(image, f"image {i}"), meta.resize_px, meta.input_size_px) for i, image in enumerate(images)]
        if not inputs:
            return np.zeros((0, len(meta.classes)), dtype=np.float32)
        outputs = []
        for start in range(0, len(inputs), batch_size):
            batch = np.stack(inputs[start:start + batch_size])
            outputs.append(self.session.run([meta.output_names[1]], {meta.input_name: batch})[0])
        return np.concatenate(outputs)

    def predict(
        self, images: Sequence[np.ndarray | str | Path], top_k: int = 5, batch_size: int = 32
    ) -> list[Prediction]:
        """Top-k models with probabilities, the top-1 model's dimensions and the expected dimensions
        (probability-weighted over the model's `expected_top_k` best classes) of each image."""
        probabilities = self.probabilities(images, batch_size)
        dims = self.metadata.dims_mm
        expected = expected_dims_mm(probabilities, dims, self.metadata.expected_top_k) if len(probabilities) else []
        predictions = []
        for row, expected_row in zip(probabilities, expected):
            order = np.argsort(-row, kind="stable")[: min(top_k, len(self.classes))]
            candidates = tuple(
                Candidate(self.classes[i].model_id, self.classes[i].make, self.classes[i].model, float(row[i]))
                for i in order
            )
            predictions.append(Prediction(candidates, dims[order[0]].copy(), expected_row))
        return predictions
