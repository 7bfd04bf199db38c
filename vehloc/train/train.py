"""`vehloc-train`: fine-tune a vehicle-model classifier (Hydra config `conf/train.yaml`), then test it and
write Table 1 into the run folder. Example: `vehloc-train experiment=demo`.

The settings are checked before Lightning is imported (`vehloc.train.params`), so a bad one is answered at
once; Ctrl-C ends the run with `vehloc-train: interrupted` and exit code 130, its last complete checkpoint
kept."""

from __future__ import annotations

from typing import Any

from omegaconf import DictConfig

from vehloc.config import config_dir
from vehloc.errors import exit_on_error, hydra_main
from vehloc.train.params import check_train_config


def train(cfg: DictConfig) -> tuple[dict[str, float], dict[str, Any]]:
    """Fit (optionally resuming from `ckpt_path`) and test with the best checkpoint; return the metrics and
    the objects of the run. The settings are checked first; a checkpoint to resume from must be of the data's
    classes (model ids and names)."""
    data, model_params = check_train_config(cfg)
    import lightning as L
    from lightning.pytorch.utilities import rank_zero_info

    from vehloc.train.checkpoints import check_classes, read_checkpoint
    from vehloc.train.instantiate import (
        instantiate_callbacks,
        instantiate_data_and_model,
        instantiate_loggers,
        instantiate_trainer,
        log_hyperparameters,
        run_trainer,
    )

    if cfg.get("seed") is not None:
        L.seed_everything(cfg.seed, workers=True, verbose=False)
    checkpoint = read_checkpoint(cfg.ckpt_path) if cfg.get("ckpt_path") else None
    datamodule, model = instantiate_data_and_model(data, model_params)
    if checkpoint is not None:
        hp = model.hparams
        check_classes(checkpoint, hp.class_model_ids, cfg.ckpt_path, hp.class_makes, hp.class_models,
                      f"data.root {datamodule.root}")
    callbacks = instantiate_callbacks(cfg.get("callbacks"))
    loggers = instantiate_loggers(cfg.get("logger"))
    trainer = instantiate_trainer(cfg, callbacks, loggers)
    log_hyperparameters(cfg, loggers)
    if cfg.get("train"):
        run_trainer(trainer, "fit", model, datamodule=datamodule, ckpt_path=cfg.get("ckpt_path"), weights_only=True)
    metrics = {k: float(v) for k, v in trainer.callback_metrics.items()}
    if cfg.get("test"):
        best = trainer.checkpoint_callback.best_model_path if trainer.checkpoint_callback else ""
        rank_zero_info(f"testing {'checkpoint ' + best if best else 'the current weights'}")
        run_trainer(trainer, "test", model, datamodule=datamodule, ckpt_path=best or None, weights_only=True)
        metrics |= {k: float(v) for k, v in trainer.callback_metrics.items()}
    objects = {"cfg": cfg, "datamodule": datamodule, "model": model, "trainer": trainer, "callbacks": callbacks}
    return metrics, objects


@exit_on_error("vehloc-train")
def _run(cfg: DictConfig) -> float | None:
    metrics, _ = train(cfg)
    return metrics.get(cfg.get("optimized_metric") or "")


@hydra_main("vehloc-train", str(config_dir()), "train")
def main(cfg: DictConfig) -> float | None:
    return _run(cfg)


if __name__ == "__main__":
    main()
