"""`vehloc-eval ckpt_path=...`: test a trained classifier (Hydra config `conf/eval.yaml`) and write Table 1,
the accuracy and dimension-error tables, the most-confused pairs and the confusion matrix into the run folder;
`vehloc-eval onnx_path=model.onnx` the same of an exported model (fp32 or INT8) through onnxruntime.

Before anything is computed, the settings are checked, the checkpoint is read (with `weights_only=True`) and
its classes are compared with the data's, model ids and names: a checkpoint scored against another data set
numbered the same way would give a plausible but meaningless Table 1."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from vehloc.config import config_dir
from vehloc.errors import exit_on_error, hydra_main
from vehloc.train.params import check_eval_config


def evaluate(cfg: DictConfig) -> tuple[dict[str, float], dict[str, Any]]:
    """Test the checkpoint `cfg.ckpt_path` on the test split of `cfg.data`, with the data's specs table.

    The test images go through the checkpoint's own preprocessing (ROI enlargement, resize, input size:
    those it was trained with), whatever the data config says."""
    data = check_eval_config(cfg)
    if cfg.get("onnx_path"):
        from vehloc.train.onnx_eval import evaluate_onnx

        return evaluate_onnx(cfg.onnx_path, data, Path(cfg.paths.output_dir) / "table1"), {"cfg": cfg}
    from vehloc.train.checkpoints import (
        check_checkpoint_file,
        check_classes,
        chosen_on_test_split,
        preprocessing_of,
        read_checkpoint,
    )
    from vehloc.train.classes import class_info, read_data

    check_checkpoint_file(cfg.ckpt_path)  # a missing checkpoint first, then the data set, both before torch loads
    dataset, specs = read_data(data.root, data.specs_csv)
    checkpoint = read_checkpoint(cfg.ckpt_path)
    preprocessing = preprocessing_of(checkpoint, cfg.ckpt_path)
    classes = class_info(dataset, specs)
    check_classes(checkpoint, classes, cfg.ckpt_path, f"data.root {data.root}")

    from vehloc.train.datamodule import CompCarsDataModule
    from vehloc.train.instantiate import (
        instantiate_callbacks,
        instantiate_loggers,
        instantiate_trainer,
        run_trainer,
    )
    from vehloc.train.module import load_classifier

    # the report opens with a warning when the checkpoint's own run chose it on this test split
    on_test = chosen_on_test_split(checkpoint)
    datamodule = CompCarsDataModule.from_params(
        dataclasses.replace(data, select_on_test=on_test, val_fraction=0.0 if on_test else data.val_fraction))
    datamodule.use_data(dataset, specs)
    datamodule.use_preprocessing(preprocessing)
    model = load_classifier(checkpoint, cfg.ckpt_path, **{k: v for k, v in classes.items() if k != "class_model_ids"})
    callbacks = instantiate_callbacks(cfg.get("callbacks"))
    loggers = instantiate_loggers(cfg.get("logger"))
    trainer = instantiate_trainer(cfg, callbacks, loggers)
    run_trainer(trainer, "test", model, datamodule=datamodule)
    metrics = {k: float(v) for k, v in trainer.callback_metrics.items()}
    return metrics, {"cfg": cfg, "datamodule": datamodule, "model": model, "trainer": trainer, "callbacks": callbacks}


@exit_on_error("vehloc-eval")
def _run(cfg: DictConfig) -> None:
    evaluate(cfg)


@hydra_main("vehloc-eval", str(config_dir()), "eval")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
