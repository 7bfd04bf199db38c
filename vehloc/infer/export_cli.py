"""`vehloc-export ckpt_path=... [output=...]`: export a classifier checkpoint to a checked ONNX file.

Before any work the settings are checked, and the output must be writable (not a folder, in a folder that can
be written); then the checkpoint and the data are read; the file replaces the output only when it has passed
every check, so a failed or interrupted export leaves an earlier file as it was."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_file
from vehloc.config import build_params, check_range, config_dir
from vehloc.errors import VehlocError, exit_on_error, hydra_main

MIN_OPSET, MAX_OPSET = 17, 23
"""The ONNX opsets vehloc exports: from 17 (LayerNormalization) to the newest torch.onnx writes."""


@dataclass(frozen=True)
class ExportParams:
    """The settings of `conf/export.yaml`."""

    ckpt_path: str
    output: str | None
    data_root: str
    parity_images: int
    opset: int
    tolerance: float
    task_name: str = "export"

    def __post_init__(self) -> None:
        check_range("parity_images", self.parity_images, 1)
        check_range("opset", self.opset, MIN_OPSET, MAX_OPSET)
        check_range("tolerance", self.tolerance, 0.0, low_open=True)


def default_output(checkpoint_path: Path) -> Path:
    """<run>/model.onnx for <run>/checkpoints/<name>.ckpt, else <name>.onnx beside the checkpoint."""
    if checkpoint_path.parent.name == "checkpoints":
        return checkpoint_path.parent.parent / "model.onnx"
    return checkpoint_path.with_suffix(".onnx")


def check_export_config(cfg: DictConfig) -> ExportParams:
    """The export's settings, checked (ConfigError naming the first bad one)."""
    if OmegaConf.is_missing(cfg, "ckpt_path") or not cfg.ckpt_path:
        raise VehlocError("ckpt_path=PATH is required: the checkpoint to export")
    values = {k: v for k, v in OmegaConf.to_container(cfg, resolve=True).items() if k not in ("paths", "hydra")}
    return build_params(ExportParams, values, "")


@exit_on_error("vehloc-export")
def _run(cfg: DictConfig) -> None:
    params = check_export_config(cfg)
    checkpoint_path = Path(params.ckpt_path)
    output = Path(params.output) if params.output else default_output(checkpoint_path)
    check_output_file(output, "output")

    from vehloc.data.compcars import read_compcars
    from vehloc.data.shapes import SHAPES_FILE, read_shapes
    from vehloc.train.checkpoints import read_checkpoint

    read_checkpoint(checkpoint_path)  # a missing or foreign checkpoint is named before the data is read
    test = read_compcars(params.data_root).test
    if not test:
        raise VehlocError(f"data_root {params.data_root}: the test split is empty; the parity check needs images")
    step = max(1, len(test) // params.parity_images)
    shapes_path = Path(params.data_root) / SHAPES_FILE
    shapes = read_shapes(shapes_path) if shapes_path.is_file() else None
    from vehloc.train.export import export_checkpoint  # torch.onnx and Lightning: after every input is checked

    report = export_checkpoint(checkpoint_path, output, test[::step][: params.parity_images], params.opset,
                               params.tolerance, shapes)
    print(
        f"wrote {report.output} (opset {report.opset}); parity on {report.parity_images} test images of "
        f"{params.data_root}: max |logit diff| {report.max_abs_logit_diff:.2e}, same top-1 on "
        f"{report.top1_agreement:.0%}" + (f"; with the shapes of {shapes_path}" if shapes else "")
    )


@hydra_main("vehloc-export", str(config_dir()), "export")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
