"""What a vehloc ONNX file carries besides its graph: classes, their dimensions, preprocessing.

Stored as one JSON document under the metadata key `vehloc`, so that a user needs nothing but the
`.onnx` file: the classes are the specs rows of their models (id, make, model, L/W/H, wheelbase), with their shapes
when the training data had them (`vehloc.data.shapes`, for the model fit), and the preprocessing is the
one of `vehloc.data.preprocess` (ROI enlargement, resize, crop, RGB in [0, 1]); the
graph takes (N, 3, S, S) inputs, normalises them itself (the preprocessing's mean/std, recorded for
reference) and returns logits and probabilities per class.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vehloc.data.preprocess import Preprocessing
from vehloc.data.shapes import VehicleShape, shapes_from_json, shapes_to_json
from vehloc.data.specs import VehicleSpec
from vehloc.errors import VehlocError

if TYPE_CHECKING:  # onnx (and the ml_dtypes it loads, a second or more) only where a model is written
    import onnx

METADATA_KEY = "vehloc"
FORMAT_VERSION = 2


class ModelFileError(VehlocError):
    """An ONNX file is missing, unreadable, or not a vehloc model."""



def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes, read in 1 MiB blocks (a checkpoint's, recorded in the metadata)."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()

@dataclass(frozen=True)
class ModelMetadata:
    """Everything needed to use an exported classifier."""

    classes: tuple[VehicleSpec, ...]
    preprocessing: Preprocessing
    backbone: str
    source_checkpoint_sha256: str
    expected_top_k: int = 5
    input_name: str = "images"
    output_names: tuple[str, str] = ("logits", "probabilities")
    format_version: int = FORMAT_VERSION
    notes: dict[str, str] = field(default_factory=dict)
    shapes: dict[int, VehicleShape] = field(default_factory=dict)

    def shape_of(self, model_id: int) -> VehicleShape:
        """The model's shape when the file carries one, else the cuboid of its dimensions."""
        if model_id in self.shapes:
            return self.shapes[model_id]
        spec = next(c for c in self.classes if c.model_id == model_id)
        return VehicleShape.cuboid(spec.length_mm, spec.width_mm, spec.height_mm)

    @property
    def precision(self) -> str:
        """The weights' and activations' precision: "fp32", or what `vehloc-export quantize=` made (notes)."""
        return self.notes.get("precision", "fp32")

    @property
    def dims_mm(self) -> np.ndarray:
        """(C, 3) length, width, height of every class, in mm."""
        return np.array([c.dims_mm for c in self.classes], dtype=float).reshape(-1, 3)

    def to_json(self) -> str:
        values = {**asdict(self), "preprocessing": self.preprocessing.as_dict()}
        values["shapes"] = shapes_to_json(self.shapes)
        return json.dumps(values, sort_keys=True)

    @classmethod
    def from_json(cls, text: str, source: str) -> ModelMetadata:
        try:
            values = json.loads(text)
            version = values.get("format_version")
            if version != FORMAT_VERSION:
                raise ModelFileError(
                    f"{source}: vehloc metadata format {version}, this vehloc reads format {FORMAT_VERSION} "
                    "(export the checkpoint again with vehloc-export)"
                )
            values["classes"] = tuple(VehicleSpec(**entry) for entry in values["classes"])
            values["preprocessing"] = Preprocessing.from_dict(values["preprocessing"])
            values["shapes"] = shapes_from_json(values["shapes"], source)
            values["output_names"] = tuple(values["output_names"])
            metadata = cls(**values)
        except (json.JSONDecodeError, KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ModelFileError(f"{source}: malformed vehloc metadata ({exc})") from None
        metadata.check(source)
        return metadata

    def check(self, source: str) -> None:
        """ModelFileError naming `source` unless the metadata is usable: classes with distinct model ids and
        finite positive dimensions, expected_top_k >= 1, two output names."""
        if not self.classes:
            raise ModelFileError(f"{source}: the vehloc metadata lists no classes")
        ids = [c.model_id for c in self.classes]
        if len(set(ids)) != len(ids):
            raise ModelFileError(f"{source}: the vehloc metadata lists a model id twice")
        for spec in self.classes:
            dims = [spec.length_mm, spec.width_mm, spec.height_mm]
            if not all(isinstance(d, (int, float)) and math.isfinite(d) and d > 0 for d in dims):
                raise ModelFileError(f"{source}: class {spec.model_id} has dimensions {dims}; they must be finite and positive")
        if not (isinstance(self.expected_top_k, int) and self.expected_top_k >= 1):
            raise ModelFileError(f"{source}: expected_top_k {self.expected_top_k!r} in the metadata is not an integer >= 1")
        if len(self.output_names) != 2:
            raise ModelFileError(f"{source}: the metadata needs two output names (logits, probabilities)")

    def check_graph(self, inputs: Sequence[tuple[str, Sequence[object]]], outputs: Sequence[tuple[str, Sequence[object]]],
                    source: str) -> None:
        """ModelFileError naming `source` unless the graph is the one the metadata describes: one input of that
        name with shape (N, 3, S, S), S the preprocessing's input size, and the two named outputs (N, C), C
        the number of classes. `inputs`, `outputs`: (name, shape) of the graph's, a dimension an int or a name."""
        size = self.preprocessing.input_size_px
        if len(inputs) != 1 or inputs[0][0] != self.input_name:
            raise ModelFileError(
                f"{source}: the graph's inputs {[name for name, _ in inputs]} are not the one input "
                f"{self.input_name!r} of its metadata")
        shape = list(inputs[0][1])
        if len(shape) != 4 or shape[1:] != [3, size, size]:
            raise ModelFileError(
                f"{source}: the graph takes input shape {_shape_text(shape)}, its metadata says (N, 3, {size}, {size})")
        by_name = {name: list(shape) for name, shape in outputs}
        for name in self.output_names:
            if name not in by_name:
                raise ModelFileError(f"{source}: the graph has no output {name!r} (its outputs: {', '.join(by_name)})")
            shape = by_name[name]
            if len(shape) != 2 or shape[1] != len(self.classes):
                raise ModelFileError(
                    f"{source}: output {name!r} has shape {_shape_text(shape)}, but the metadata lists "
                    f"{len(self.classes)} classes")


def _shape_text(shape: Sequence[object]) -> str:
    return "(" + ", ".join("N" if not isinstance(d, int) else str(d) for d in shape) + ")"


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
