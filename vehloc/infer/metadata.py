"""What a vehloc ONNX file carries besides its graph: classes, their dimensions, preprocessing.

Stored as one JSON document under the metadata key `vehloc`, so that a user needs nothing but the
`.onnx` file: the classes are the specs rows of their models (id, make, model, L/W/H, wheelbase); the graph takes RGB images scaled to [0, 1] (N, 3, S, S), normalises them itself
(mean/std below, recorded for reference) and returns logits and probabilities per class.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field

import numpy as np
import onnx

from vehloc.data.specs import VehicleSpec
from vehloc.errors import VehlocError

METADATA_KEY = "vehloc"
FORMAT_VERSION = 1


class ModelFileError(VehlocError):
    """An ONNX file is missing, unreadable, or not a vehloc model."""


@dataclass(frozen=True)
class ModelMetadata:
    """Everything needed to use an exported classifier."""

    classes: tuple[VehicleSpec, ...]
    input_size_px: int
    resize_px: int
    roi_enlarge_fraction: float
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    backbone: str
    source_checkpoint_sha256: str
    expected_top_k: int = 5
    colour_order: str = "RGB"
    input_range: tuple[float, float] = (0.0, 1.0)
    input_name: str = "images"
    output_names: tuple[str, str] = ("logits", "probabilities")
    format_version: int = FORMAT_VERSION
    notes: dict[str, str] = field(default_factory=dict)

    @property
    def dims_mm(self) -> np.ndarray:
        """(C, 3) length, width, height of every class, in mm."""
        return np.array([c.dims_mm for c in self.classes], dtype=float).reshape(-1, 3)

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True)

    @classmethod
    def from_json(cls, text: str, source: str) -> ModelMetadata:
        try:
            values = json.loads(text)
            values["classes"] = tuple(VehicleSpec(**entry) for entry in values["classes"])
            for key in ("mean", "std", "input_range", "output_names"):
                values[key] = tuple(values[key])
            return cls(**values)
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise ModelFileError(f"{source}: malformed vehloc metadata ({exc})") from None


def attach_metadata(model: onnx.ModelProto, metadata: ModelMetadata) -> None:
    """Store the metadata in the model (replacing an earlier vehloc entry)."""
    kept = [p for p in model.metadata_props if p.key != METADATA_KEY]
    del model.metadata_props[:]
    model.metadata_props.extend(kept)
    entry = model.metadata_props.add()
    entry.key, entry.value = METADATA_KEY, metadata.to_json()


def read_metadata(metadata_map: dict[str, str], source: str) -> ModelMetadata:
    """The vehloc metadata of a model's metadata map (onnx or onnxruntime), or ModelFileError."""
    if METADATA_KEY not in metadata_map:
        raise ModelFileError(f"{source}: an ONNX model without vehloc metadata (export it with vehloc-export)")
    return ModelMetadata.from_json(metadata_map[METADATA_KEY], source)
