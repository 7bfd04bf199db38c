"""INT8 static quantization of an exported classifier, checked before it lands (onnxruntime; no torch).

onnxruntime's recipe for CNNs: the model prepared (`quant_pre_process`: shapes inferred, graph optimised), then
static QDQ quantization of the convolutions, matrix products and the element-wise and pooling operators between
them, with per-channel int8 weights and uint8 activations whose ranges come from calibration images read through
the model's own preprocessing (the ROI enlargement, resize and crop of every other use); the input's
normalisation and the head (the last fully connected layer and what follows it: the logits and the softmax) stay
float, so that the class probabilities a track's vote averages are not on an 8-bit grid (which ties classes). `reduce_range` (7-bit weights) is chosen from the CPU: without
int8 dot products (VNNI) x86's u8 x s8 multiply can saturate, with them full range is exact.

The quantized file carries the fp32 model's vehloc metadata plus notes on what was quantized and how and the
figures it was checked on; it replaces its output only when its top-1 agrees with the fp32 model's on the parity
images, and the accuracy of both on the test split is measured and stated.
"""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vehloc.atomic import atomic_path
from vehloc.config import check_choice, check_range
from vehloc.data.compcars import CompCarsSample
from vehloc.errors import VehlocError
from vehloc.hardware import CpuInfo, cpu_info
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.labelled import LabelledPredictions, predict_labelled
from vehloc.infer.metadata import ModelMetadata, attach_metadata, file_sha256

if TYPE_CHECKING:  # onnx (and the ml_dtypes it loads, a second or more) only where a model is quantized
    import onnx

QUANTIZE_MODES = ("none", "int8")
CALIBRATION_METHODS = ("minmax", "entropy", "percentile")
QUANTIZED_OPS = ("Conv", "MatMul", "Gemm", "Add", "Mul", "Relu", "Clip", "MaxPool", "AveragePool",
                 "GlobalAveragePool", "Concat")
"""The operators quantized: the network between its float normalisation and its float head (`head_nodes`)."""
HEAD_OPS = ("Gemm", "MatMul")
PROVIDERS = ["CPUExecutionProvider"]


class QuantizationError(VehlocError):
    """The quantized model failed its check, or its input cannot be quantized; the output was left as it was."""


@dataclass(frozen=True)
class Int8Settings:
    """The `int8.*` settings of `vehloc-export quantize=int8`."""

    calibration_images: int = 300
    calibration_method: str = "minmax"
    per_channel: bool = True
    reduce_range: bool | None = None
    min_top1_agreement: float = 0.9
    output: str | None = None

    def __post_init__(self) -> None:
        check_range("calibration_images", self.calibration_images, 1)
        check_choice("calibration_method", self.calibration_method, CALIBRATION_METHODS)
        check_range("min_top1_agreement", self.min_top1_agreement, 0.0, 1.0, low_open=True)


@dataclass(frozen=True)
class Int8Report:
    """What a quantization wrote and how the INT8 model compares with the fp32 one."""

    output: Path
    reduce_range: bool
    reduce_range_reason: str
    calibration_images: int
    parity: tuple[LabelledPredictions, LabelledPredictions]
    test: tuple[LabelledPredictions, LabelledPredictions]

    @property
    def parity_agreement(self) -> float:
        return self.parity[0].top1_agreement(self.parity[1])

    @property
    def top1_loss_pts(self) -> float:
        """fp32 minus INT8 top-1 on the test split, in percentage points (negative: INT8 is better)."""
        return self.test[0].top1_pct - self.test[1].top1_pct


def default_int8_output(fp32_path: Path) -> Path:
    """`<name>.int8.onnx` beside the fp32 `<name>.onnx`."""
    return fp32_path.with_name(fp32_path.stem + ".int8.onnx")


def reduce_range_for(setting: bool | None, cpu: CpuInfo) -> tuple[bool, str]:
    """`reduce_range` and why: as set, or (None) on exactly when the CPU has no int8 dot products."""
    if setting is not None:
        return setting, "as set"
    if cpu.int8_dot_product:
        return False, "this CPU has int8 dot products (VNNI)"
    return True, "this CPU has no int8 dot products (no VNNI)"


def quantize_classifier(
    fp32_path: Path, output: Path, calibration: Sequence[CompCarsSample], parity: Sequence[CompCarsSample],
    test: Sequence[CompCarsSample], settings: Int8Settings, data_name: str, cpu: CpuInfo | None = None,
) -> Int8Report:
    """Quantize the fp32 vehloc model at `fp32_path` into `output` (see the module docstring): calibrated on
    `calibration`, checked on `parity`, both measured on `test` (labelled images of `data_name`)."""
    fp32 = VehicleClassifier.from_onnx(fp32_path, PROVIDERS)
    if fp32.metadata.precision != "fp32":
        raise QuantizationError(f"{fp32_path}: is already an {fp32.metadata.precision} model; quantize its fp32 model")
    if not calibration or not parity:
        raise QuantizationError(f"{data_name}: {'no calibration' if not calibration else 'no parity'} images")
    reduce_range, reason = reduce_range_for(settings.reduce_range, cpu or cpu_info())
    inputs = fp32.inputs([s.image_path for s in calibration], [s.box for s in calibration])
    metadata = replace(fp32.metadata, notes={
        **fp32.metadata.notes, "precision": "int8",
        "quantization": (f"onnxruntime static QDQ: uint8 activations, int8 weights "
                         f"{'per channel' if settings.per_channel else 'per tensor'}, reduce_range "
                         f"{str(reduce_range).lower()} ({reason}); {', '.join(QUANTIZED_OPS)}; the head float"),
        "calibration": f"{len(calibration)} training images of {data_name}, {settings.calibration_method}",
        "fp32_model_sha256": file_sha256(fp32_path),
    })
    with tempfile.TemporaryDirectory(prefix="vehloc-int8-") as scratch, atomic_path(output) as temporary:
        _quantize(fp32_path, Path(scratch), temporary, inputs, fp32.metadata.input_name, settings, reduce_range)
        _save_with_metadata(temporary, metadata)
        int8 = VehicleClassifier.from_onnx(temporary, PROVIDERS)
        parity_pair = (predict_labelled(fp32, parity), predict_labelled(int8, parity))
        agreement = parity_pair[0].top1_agreement(parity_pair[1])
        if agreement < settings.min_top1_agreement:
            raise QuantizationError(
                f"the INT8 model agrees with the fp32 one on {agreement:.1%} of {len(parity)} parity images "
                f"(int8.min_top1_agreement {settings.min_top1_agreement:.0%}); {output} left unchanged")
        test_pair = (predict_labelled(fp32, test, progress="test split, fp32"),
                     predict_labelled(int8, test, progress="test split, int8"))
        _save_with_metadata(temporary, replace(metadata, notes={
            **metadata.notes, "parity_top1_agreement": f"{agreement:.4f} on {len(parity)} test images",
            "test_top1_fp32_pct": f"{test_pair[0].top1_pct:.2f}", "test_top1_int8_pct": f"{test_pair[1].top1_pct:.2f}",
            "test_images": str(len(test)),
        }))
    return Int8Report(output, reduce_range, reason, len(calibration), parity_pair, test_pair)


def _quantize(fp32_path: Path, scratch: Path, output: Path, inputs: np.ndarray, input_name: str,
              settings: Int8Settings, reduce_range: bool) -> None:
    from onnxruntime.quantization import (
        CalibrationDataReader,
        CalibrationMethod,
        QuantFormat,
        QuantType,
        quant_pre_process,
        quantize_static,
    )

    class OneImageAtATime(CalibrationDataReader):
        def __init__(self) -> None:
            self.next_index = 0

        def get_next(self) -> dict[str, np.ndarray] | None:
            if self.next_index >= len(inputs):
                return None
            self.next_index += 1
            return {input_name: inputs[self.next_index - 1:self.next_index]}

    import onnx

    prepared = scratch / "prepared.onnx"
    quant_pre_process(str(fp32_path), str(prepared), skip_symbolic_shape=True)
    head = head_nodes(onnx.load(str(prepared)))
    method = {"minmax": CalibrationMethod.MinMax, "entropy": CalibrationMethod.Entropy,
              "percentile": CalibrationMethod.Percentile}[settings.calibration_method]
    root_logger = logging.getLogger()
    level = root_logger.level
    root_logger.setLevel(logging.WARNING)  # the quantizer logs a line per rescaled bias at INFO
    try:
        quantize_static(
            str(prepared), str(output), OneImageAtATime(), quant_format=QuantFormat.QDQ,
            per_channel=settings.per_channel, reduce_range=reduce_range, activation_type=QuantType.QUInt8,
            weight_type=QuantType.QInt8, calibrate_method=method, op_types_to_quantize=list(QUANTIZED_OPS),
            nodes_to_exclude=head,
        )
    finally:
        root_logger.setLevel(level)


def head_nodes(model: onnx.ModelProto) -> list[str]:
    """The names of the graph's last fully connected node (Gemm or MatMul, in the graph's topological order) and of
    every node downstream of it."""
    nodes = list(model.graph.node)
    last = max((i for i, node in enumerate(nodes) if node.op_type in HEAD_OPS), default=None)
    if last is None:
        return []
    produced, head = set(nodes[last].output), [nodes[last].name]
    for node in nodes[last + 1:]:
        if produced & set(node.input):
            produced |= set(node.output)
            head.append(node.name)
    return [name for name in head if name]


def _save_with_metadata(path: Path, metadata: ModelMetadata) -> None:
    import onnx

    model = onnx.load(str(path))
    attach_metadata(model, metadata)
    onnx.save(model, str(path))
    onnx.checker.check_model(str(path), full_check=True)
