"""The onnxruntime vehicle classifier that everything downstream uses: vehicle images (ROI crops, or whole
images with their vehicle boxes) in, models and dimensions out."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnxruntime as ort

from vehloc.data.boxes import Box
from vehloc.data.dimension_error import expected_dims_mm
from vehloc.data.specs import VehicleSpec
from vehloc.infer.metadata import ModelFileError, ModelMetadata, read_metadata
from vehloc.infer.preprocess import ImageInputError, load_bgr


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
            raise ModelFileError(f"{path}: model file does not exist" + (" (it is a folder)" if path.is_dir() else ""))
        try:
            session = ort.InferenceSession(str(path), providers=list(providers or default_providers()))
        except Exception as exc:  # onnxruntime raises its own exception types for corrupt files
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ModelFileError(f"{path}: not a loadable ONNX model ({reason[:300]})") from None
        metadata = read_metadata(session.get_modelmeta().custom_metadata_map, str(path))
        metadata.check_graph([(i.name, i.shape) for i in session.get_inputs()],
                             [(o.name, o.shape) for o in session.get_outputs()], str(path))
        return cls(session, metadata, str(path))

    @property
    def classes(self) -> tuple[VehicleSpec, ...]:
        return self.metadata.classes

    def inputs(self, images: Sequence[np.ndarray | str | Path], boxes: Sequence[Box] | None = None) -> np.ndarray:
        """(N, 3, S, S) network inputs of BGR images or image paths: each image whole, or, with `boxes`, its
        vehicle ROI (the box enlarged as in training), through the model's preprocessing."""
        if boxes is not None and len(boxes) != len(images):
            raise ValueError(f"{len(images)} images but {len(boxes)} boxes")
        preprocessing = self.metadata.preprocessing
        inputs = []
        for i, image in enumerate(images):
            name = str(image) if isinstance(image, (str, Path)) else f"image {i}"
            bgr = load_bgr(image, name)
            if boxes is not None:
                try:
                    bgr = load_bgr(preprocessing.roi(bgr, boxes[i]), f"{name}, box {boxes[i].as_tuple()}")
                except ValueError as err:
                    raise ImageInputError(f"{name}: {err}") from None
            inputs.append(preprocessing.to_input(bgr))
        size = preprocessing.input_size_px
        return np.stack(inputs) if inputs else np.zeros((0, 3, size, size), np.float32)

    def _run(self, inputs: np.ndarray, output: str, batch_size: int) -> np.ndarray:
        meta = self.metadata
        if not len(inputs):
            return np.zeros((0, len(meta.classes)), dtype=np.float32)
        return np.concatenate([
            self.session.run([output], {meta.input_name: inputs[start:start + batch_size]})[0]
            for start in range(0, len(inputs), batch_size)
        ])

    def logits(self, images: Sequence[np.ndarray | str | Path], boxes: Sequence[Box] | None = None,
               batch_size: int = 32) -> np.ndarray:
        """(N, C) class logits (see `inputs`)."""
        return self._run(self.inputs(images, boxes), self.metadata.output_names[0], batch_size)

    def probabilities(self, images: Sequence[np.ndarray | str | Path], boxes: Sequence[Box] | None = None,
                      batch_size: int = 32) -> np.ndarray:
        """(N, C) class probabilities (see `inputs`)."""
        return self._run(self.inputs(images, boxes), self.metadata.output_names[1], batch_size)

    def predict(
        self, images: Sequence[np.ndarray | str | Path], top_k: int = 5, batch_size: int = 32,
        boxes: Sequence[Box] | None = None,
    ) -> list[Prediction]:
        """Top-k models with probabilities, the top-1 model's dimensions and the expected dimensions
        (probability-weighted over the model's `expected_top_k` best classes) of each image (see `inputs`)."""
        return self.predictions(self.probabilities(images, boxes, batch_size), top_k)

    def predictions(self, probabilities: np.ndarray, top_k: int = 5) -> list[Prediction]:
        """Predictions from (N, C) class probabilities (e.g. averaged over a track's frames)."""
        if top_k < 1:
            raise ValueError(f"top_k must be at least 1, got {top_k}")
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
