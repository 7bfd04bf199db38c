"""`vehloc-export ckpt_path=... [output=...]`: export a classifier checkpoint to a checked ONNX file."""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from vehloc.data.compcars import read_compcars
from vehloc.data.shapes import SHAPES_FILE, read_shapes
from vehloc.config import config_dir
from vehloc.errors import VehlocError, exit_on_error
from vehloc.infer.export import export_checkpoint
from vehloc.train.module import read_checkpoint


def default_output(checkpoint_path: Path) -> Path:
    """<run>/model.onnx for <run>/checkpoints/<name>.ckpt, else <name>.onnx beside the checkpoint."""
    if checkpoint_path.parent.name == "checkpoints":
        return checkpoint_path.parent.parent / "model.onnx"
    return checkpoint_path.with_suffix(".onnx")


@exit_on_error("vehloc-export")
def _run(cfg: DictConfig) -> None:
    if OmegaConf.is_missing(cfg, "ckpt_path") or not cfg.ckpt_path:
        raise VehlocError("ckpt_path=PATH is required: the checkpoint to export")
    checkpoint_path = Path(cfg.ckpt_path)
    read_checkpoint(checkpoint_path)  # a missing or foreign checkpoint is named before the data is read
    test = read_compcars(cfg.data_root).test
    step = max(1, len(test) // cfg.parity_images)
    output = Path(cfg.output) if cfg.output else default_output(checkpoint_path)
    shapes_path = Path(cfg.data_root) / SHAPES_FILE
    shapes = read_shapes(shapes_path) if shapes_path.is_file() else None
    report = export_checkpoint(checkpoint_path, output, test[::step][: cfg.parity_images], cfg.opset, cfg.tolerance,
                               shapes)
    print(
        f"wrote {report.output} (opset {report.opset}); parity on {report.parity_images} test images of "
        f"{cfg.data_root}: max |logit diff| {report.max_abs_logit_diff:.2e}, same top-1 on {report.top1_agreement:.0%}"
        + (f"; with the shapes of {shapes_path}" if shapes else "")
    )


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="export")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
