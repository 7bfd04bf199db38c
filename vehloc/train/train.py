"""`vehloc-train`: fine-tune a vehicle-model classifier (Hydra config `conf/train.yaml`), then test it and
write Table 1 into the run folder. Example: `vehloc-train experiment=demo`.

The settings, the data set with its specs table and a checkpoint to resume from are checked before Lightning is
imported (`vehloc.train.params`, `vehloc.train.classes`), so bad input is answered at once; Ctrl-C ends the run
with `vehloc-train: interrupted` and exit code 130, its last complete checkpoint kept."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from vehloc.config import config_dir
from vehloc.errors import exit_on_error, hydra_main
from vehloc.train.classes import class_info, read_data
from vehloc.train.params import check_train_config


def train(cfg: DictConfig) -> tuple[dict[str, float], dict[str, Any]]:
    """Fit (optionally resuming from `ckpt_path`) and test with the best checkpoint; return the metrics and
    the objects of the run. The settings are checked first; a checkpoint to resume from must be of the data's
    classes (model ids and names)."""
    data, model_params = check_train_config(cfg)
    dataset, specs = read_data(data.root, data.specs_csv)
    if cfg.get("ckpt_path"):
        from vehloc.train.checkpoints import check_classes, read_checkpoint

        check_classes(read_checkpoint(cfg.ckpt_path), class_info(dataset, specs), cfg.ckpt_path,
                      f"data.root {Path(data.root)}")
    import lightning as L
    from lightning.pytorch.utilities import rank_zero_info

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
    datamodule, model = instantiate_data_and_model(data, model_params, (dataset, specs))
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
