"""Export a trained classifier checkpoint to one self-contained ONNX file, checked before it lands.

The eval-mode model (single output, no auxiliary heads) with its normalisation and a softmax goes to
ONNX with a dynamic batch axis; the file gets the vehloc metadata, passes
`onnx.checker.check_model(full_check=True)`, and must reproduce the PyTorch logits on real images, each
side from the image file through its own pipeline: the training code's evaluation data set for PyTorch,
the onnxruntime classifier for ONNX (max abs difference and identical top-1). It is written under a
temporary name and renamed over the output only then, so a failed or interrupted export never replaces a good
file.

It lives with training because it needs torch; `vehloc.infer`, what it writes for, does not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import onnx
import torch

from vehloc.atomic import atomic_path
from vehloc.data.compcars import CompCarsSample
from vehloc.data.shapes import VehicleShape
from vehloc.data.specs import VehicleSpec
from vehloc.errors import VehlocError
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.metadata import ModelMetadata, attach_metadata, file_sha256
from vehloc.train.dataset import CompCarsCrops
from vehloc.train.module import LitVehicleClassifier, load_classifier, preprocessing_of, read_checkpoint
from vehloc.train.transforms import EvalTransform

DEFAULT_OPSET = 18


class ExportError(VehlocError):
    """The exported model failed a check; the output file was left as it was."""


@dataclass(frozen=True)
class ExportReport:
    """What an export wrote and how closely the ONNX model reproduced the PyTorch one."""

    output: Path
    opset: int
    parity_images: int
    max_abs_logit_diff: float
    top1_agreement: float


class DeployedClassifier(torch.nn.Module):
    """The classifier as deployed: RGB [0, 1] images in, logits and probabilities out."""

    def __init__(self, classifier: LitVehicleClassifier) -> None:
        super().__init__()
        self.classifier = classifier

    def forward(self, images: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        logits = self.classifier(images)
        return logits, torch.softmax(logits, dim=1)


def metadata_of(checkpoint: dict, checkpoint_path: Path, shapes: dict[int, VehicleShape] | None = None) -> ModelMetadata:
    """The metadata of a checkpoint's classifier: its class table and preprocessing, and the shapes of those
    of its classes that `shapes` has."""
    hp = checkpoint["hyper_parameters"]
    wheelbases = hp.get("class_wheelbases_mm") or [None] * len(hp["class_model_ids"])
    classes = tuple(
        VehicleSpec(int(model_id), str(make), str(model), *map(float, dims), wheelbase)
        for model_id, make, model, dims, wheelbase in zip(
            hp["class_model_ids"], hp["class_makes"], hp["class_models"], hp["class_dims_mm"], wheelbases
        )
    )
    return ModelMetadata(
        classes=classes,
        preprocessing=preprocessing_of(checkpoint, checkpoint_path),
        backbone=str(hp["backbone"]["name"]),
        source_checkpoint_sha256=file_sha256(checkpoint_path),
        expected_top_k=int(hp.get("expected_top_k", 5)),
        shapes={c.model_id: shapes[c.model_id] for c in classes if shapes and c.model_id in shapes},
    )


def pytorch_inputs(samples: Sequence[CompCarsSample], metadata: ModelMetadata) -> torch.Tensor:
    """The evaluation inputs of labelled images as training's data set makes them, from the files."""
    preprocessing = metadata.preprocessing
    dataset = CompCarsCrops(samples, [0] * len(samples), EvalTransform(preprocessing), preprocessing.roi_enlarge_fraction)
    return torch.stack([dataset[i][0] for i in range(len(dataset))])


def export_checkpoint(
    checkpoint_path: Path,
    output: Path,
    parity_samples: Sequence[CompCarsSample],
    opset: int = DEFAULT_OPSET,
    tolerance: float = 1e-4,
    shapes: dict[int, VehicleShape] | None = None,
    checkpoint: dict[str, Any] | None = None,
) -> ExportReport:
    """Export, check and atomically place the ONNX model of a checkpoint (see the module docstring); the
    parity check runs on `parity_samples`, labelled images of the checkpoint's kind. `shapes` (by model id)
    go into the metadata for the classes they cover; `checkpoint`: the file's contents where the caller has
    read them already (`read_checkpoint`), else they are read here."""
    if opset < 17:
        raise ExportError(f"opset {opset} is below 17, the lowest vehloc exports")
    if not parity_samples:
        raise ExportError("the parity check needs at least one real image")
    checkpoint = read_checkpoint(checkpoint_path) if checkpoint is None else checkpoint
    metadata = metadata_of(checkpoint, Path(checkpoint_path), shapes)
    deployed = DeployedClassifier(load_classifier(checkpoint, checkpoint_path)).eval()
    images = pytorch_inputs(parity_samples, metadata)

    output = Path(output)
    with atomic_path(output) as temporary:
        example = images[:2]
        torch.onnx.export(
            deployed, (example,), str(temporary), input_names=[metadata.input_name],
            output_names=list(metadata.output_names), opset_version=opset, dynamo=True,
            dynamic_shapes=({0: torch.export.Dim("batch", min=1, max=4096)},), external_data=False,
        )
        model = onnx.load(str(temporary))
        attach_metadata(model, metadata)
        onnx.save(model, str(temporary))
        onnx.checker.check_model(str(temporary), full_check=True)
        report = _parity(deployed, temporary, images, parity_samples, tolerance, opset, output)
    return report


def _parity(
    deployed: DeployedClassifier, path: Path, images: torch.Tensor, samples: Sequence[CompCarsSample],
    tolerance: float, opset: int, output: Path,
) -> ExportReport:
    with torch.no_grad():
        eager = deployed(images)[0].numpy()
    classifier = VehicleClassifier.from_onnx(path, providers=["CPUExecutionProvider"])
    exported = classifier.logits([s.image_path for s in samples], [s.box for s in samples])
    max_diff = float(np.max(np.abs(exported - eager)))
    agreement = float(np.mean(exported.argmax(axis=1) == eager.argmax(axis=1)))
    if max_diff > tolerance or agreement < 1.0:
        raise ExportError(
            f"ONNX model disagrees with PyTorch on {len(images)} images: max |logit diff| {max_diff:.2e} "
            f"(tolerance {tolerance:.0e}), same top-1 on {agreement:.1%}; {output} left unchanged"
        )
    return ExportReport(output, opset, len(images), max_diff, agreement)
