"""`vehloc-eval ckpt_path=...`: test a trained classifier (Hydra config `conf/eval.yaml`) and write Table 1,
the accuracy and dimension-error tables, the most-confused pairs and the confusion matrix into the run folder."""

from __future__ import annotations

from typing import Any

import hydra
from omegaconf import DictConfig, OmegaConf

from vehloc.config import config_dir
from vehloc.errors import VehlocError, exit_on_error
from vehloc.train.instantiate import instantiate_callbacks, instantiate_loggers, instantiate_trainer
from vehloc.train.module import check_classes, load_classifier, preprocessing_of, read_checkpoint


def evaluate(cfg: DictConfig) -> tuple[dict[str, float], dict[str, Any]]:
    """Test the checkpoint `cfg.ckpt_path` on the test split of `cfg.data`, with the data's specs table.

    The test images go through the checkpoint's own preprocessing (ROI enlargement, resize, input size:
    those it was trained with), whatever the data config says."""
    if OmegaConf.is_missing(cfg, "ckpt_path") or not cfg.ckpt_path:
        raise VehlocError("ckpt_path=PATH is required: the checkpoint to evaluate")
    checkpoint = read_checkpoint(cfg.ckpt_path)
    datamodule = hydra.utils.instantiate(cfg.data, _convert_="all")
    datamodule.use_preprocessing(preprocessing_of(checkpoint, cfg.ckpt_path))
    classes = datamodule.class_info()
    check_classes(checkpoint, classes["class_model_ids"], cfg.ckpt_path)
    model = load_classifier(checkpoint, **{k: v for k, v in classes.items() if k != "class_model_ids"})
    callbacks = instantiate_callbacks(cfg.get("callbacks"))
    loggers = instantiate_loggers(cfg.get("logger"))
    trainer = instantiate_trainer(cfg, callbacks, loggers)
    trainer.test(model, datamodule=datamodule)
    metrics = {k: float(v) for k, v in trainer.callback_metrics.items()}
    return metrics, {"cfg": cfg, "datamodule": datamodule, "model": model, "trainer": trainer, "callbacks": callbacks}


@exit_on_error("vehloc-eval")
def _run(cfg: DictConfig) -> None:
    evaluate(cfg)


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="eval")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
