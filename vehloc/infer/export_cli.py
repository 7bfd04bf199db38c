"""`vehloc-export ckpt_path=... [output=...] [quantize=int8]`: export a classifier checkpoint to a checked ONNX
file, and with `quantize=int8` an INT8 model beside it (`onnx_path=model.onnx quantize=int8`: of an earlier export).

Before any work the settings are checked, and the outputs must be writable (not a folder, in a folder that can
be written, never one of the inputs); then the checkpoint is checked to be a file, the data read and the
checkpoint loaded (as `vehloc-eval` does: a missing data set is named before torch loads); each file replaces its
output only when it has passed every check, so a failed or interrupted export leaves an earlier file as it was."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_file
from vehloc.config import build_params, check_choice, check_range, config_dir
from vehloc.data.compcars import CompCarsSample, CompCarsSet, read_compcars
from vehloc.errors import VehlocError, exit_on_error, hydra_main
from vehloc.infer.quantize import QUANTIZE_MODES, Int8Settings, default_int8_output

MIN_OPSET, MAX_OPSET = 17, 23
"""The ONNX opsets vehloc exports: from 17 (LayerNormalization) to the newest torch.onnx writes."""


@dataclass(frozen=True)
class ExportParams:
    """The settings of `conf/export.yaml`."""

    ckpt_path: str | None
    output: str | None
    data_root: str
    parity_images: int
    opset: int
    tolerance: float
    quantize: str
    int8: Int8Settings
    onnx_path: str | None = None
    task_name: str = "export"

    def __post_init__(self) -> None:
        check_range("parity_images", self.parity_images, 1)
        check_range("opset", self.opset, MIN_OPSET, MAX_OPSET)
        check_range("tolerance", self.tolerance, 0.0, low_open=True)
        check_choice("quantize", self.quantize, QUANTIZE_MODES)


def default_output(checkpoint_path: Path) -> Path:
    """<run>/model.onnx for <run>/checkpoints/<name>.ckpt, else <name>.onnx beside the checkpoint."""
    if checkpoint_path.parent.name == "checkpoints":
        return checkpoint_path.parent.parent / "model.onnx"
    return checkpoint_path.with_suffix(".onnx")


def check_export_config(cfg: DictConfig) -> ExportParams:
    """The export's settings, checked (ConfigError naming the first bad one)."""
    values = {k: v for k, v in OmegaConf.to_container(cfg, resolve=True).items() if k not in ("paths", "hydra")}
    values.update({k: None for k in ("ckpt_path", "onnx_path") if OmegaConf.is_missing(cfg, k)})
    params = build_params(ExportParams, values, "")
    if bool(params.ckpt_path) == bool(params.onnx_path):
        raise VehlocError("ckpt_path=PATH is required: the checkpoint to export (or onnx_path=MODEL.onnx "
                          "quantize=int8 to quantize an earlier export)" if not params.onnx_path else
                          "give ckpt_path= or onnx_path=, not both")
    if params.ckpt_path and Path(params.ckpt_path).suffix.lower() == ".onnx":
        raise VehlocError(f"ckpt_path {params.ckpt_path}: is an ONNX model, not a checkpoint; to quantize an "
                          f"exported model: onnx_path={params.ckpt_path} quantize=int8")
    if params.onnx_path and params.quantize == "none":
        raise VehlocError(f"onnx_path {params.onnx_path}: an exported model is only quantized here; add quantize=int8")
    return params


def output_paths(params: ExportParams) -> tuple[Path | None, Path | None]:
    """The fp32 model's output (None when quantizing an earlier export) and the INT8 one's (None without
    quantize=int8), each checked writable and neither an input nor the other."""
    inputs = [p for p in (params.ckpt_path, params.onnx_path) if p]
    fp32 = None
    if params.ckpt_path:
        fp32 = Path(params.output) if params.output else default_output(Path(params.ckpt_path))
        check_output_file(fp32, "output", inputs)
    int8 = None
    if params.quantize == "int8":
        int8 = Path(params.int8.output) if params.int8.output else default_int8_output(fp32 or Path(params.onnx_path))
        check_output_file(int8, "int8.output", inputs)
    if fp32 is not None and int8 is not None and fp32.resolve() == int8.resolve():
        raise VehlocError(f"int8.output {int8}: is the fp32 model's output too; give the INT8 model its own file")
    return fp32, int8


@exit_on_error("vehloc-export")
def _run(cfg: DictConfig) -> None:
    params = check_export_config(cfg)
    fp32_output, int8_output = output_paths(params)

    if params.ckpt_path:
        from vehloc.train.checkpoints import check_checkpoint_file, read_checkpoint

        check_checkpoint_file(params.ckpt_path)  # a missing checkpoint is named first, before torch loads
    else:
        from vehloc.infer.classifier import VehicleClassifier

        model = VehicleClassifier.from_onnx(params.onnx_path, ["CPUExecutionProvider"])  # named before the data is read
        if model.metadata.precision != "fp32":
            raise VehlocError(f"onnx_path {params.onnx_path}: is already an {model.metadata.precision} model; "
                              "quantize its fp32 model")
    data = read_compcars(params.data_root)
    if not data.test:
        raise VehlocError(f"data_root {params.data_root}: the test split is empty; the parity check needs images")
    if int8_output is not None and not data.train:
        raise VehlocError(f"data_root {params.data_root}: the train split is empty; INT8 calibration needs images")
    # a foreign checkpoint is named before torch.onnx and Lightning load; the export takes it as read
    checkpoint = read_checkpoint(Path(params.ckpt_path)) if params.ckpt_path else None
    parity = data.test[:: max(1, len(data.test) // params.parity_images)][: params.parity_images]
    fp32_model = Path(params.onnx_path) if params.onnx_path else _export(params, checkpoint, fp32_output, parity)
    if int8_output is not None:
        _quantize(params, fp32_model, int8_output, data, parity)


def _export(params: ExportParams, checkpoint: dict[str, Any], output: Path, parity: Sequence[CompCarsSample]) -> Path:
    from vehloc.data.shapes import SHAPES_FILE, read_shapes

    shapes_path = Path(params.data_root) / SHAPES_FILE
    shapes = read_shapes(shapes_path) if shapes_path.is_file() else None
    from vehloc.train.export import export_checkpoint  # torch.onnx and Lightning: after every input is checked

    report = export_checkpoint(Path(params.ckpt_path), output, parity, params.opset, params.tolerance, shapes,
                               checkpoint=checkpoint)
    print(
        f"wrote {report.output} (opset {report.opset}); parity on {report.parity_images} test images of "
        f"{params.data_root}: max |logit diff| {report.max_abs_logit_diff:.2e}, same top-1 on "
        f"{report.top1_agreement:.0%}" + (f"; with the shapes of {shapes_path}" if shapes else "")
    )
    return output


def _quantize(params: ExportParams, fp32_model: Path, output: Path, data: CompCarsSet,
              parity: Sequence[CompCarsSample]) -> None:
    from vehloc.infer.quantize import quantize_classifier

    settings = params.int8
    calibration = data.train[:: max(1, len(data.train) // settings.calibration_images)][: settings.calibration_images]
    report = quantize_classifier(fp32_model, output, calibration, parity, data.test, settings, params.data_root)
    fp32_test, int8_test = report.test
    print(
        f"wrote {report.output} (INT8, reduce_range {str(report.reduce_range).lower()}: {report.reduce_range_reason}; "
        f"calibrated on {report.calibration_images} training images); same top-1 as the fp32 model on "
        f"{report.parity_agreement:.0%} of {len(parity)} parity images; test split ({len(data.test)} images): top-1 "
        f"fp32 {fp32_test.top1_pct:.2f} %, INT8 {int8_test.top1_pct:.2f} % (loss {report.top1_loss_pts:+.2f} points)"
    )


@hydra_main("vehloc-export", str(config_dir()), "export")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
