"""Every config composes and instantiates: experiments, trainers, loggers, the eval root."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import hydra
import lightning as L
import pytest

from vehloc.config import config_dir
from vehloc.train.instantiate import (
    compose_config,
    instantiate_callbacks,
    instantiate_data_and_model,
    instantiate_loggers,
    instantiate_trainer,
)
from vehloc.train.params import check_train_config

PROJECT_ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = sorted(p.stem for p in (config_dir() / "experiment").glob("*.yaml"))


def test_the_issue_s_experiments_exist():
    assert {"demo", "paper_googlenet_compcars431", "stanford_cars_12"} <= set(EXPERIMENTS)


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_experiment_composes_and_instantiates(experiment: str, tiny_root: Path, stanford_root: Path, tmp_path: Path):
    overrides = [f"experiment={experiment}", "trainer.accelerator=cpu", "trainer.devices=1",
                 "trainer.precision=32-true"]
    if experiment == "stanford_cars_12":
        overrides.append(f"paths.root_dir={PROJECT_ROOT}")  # the data lie in ../shared/data
    else:
        overrides.append(f"data.root={tiny_root}")
    if experiment == "paper_googlenet_compcars431":
        overrides.append("model.backbone.pretrained=none")  # the ImageNet file is not in this cache
    cfg = compose_config("train", overrides, tmp_path)
    datamodule, model = instantiate_data_and_model(*check_train_config(cfg))
    trainer = instantiate_trainer(cfg, instantiate_callbacks(cfg.callbacks), instantiate_loggers(cfg.logger))
    assert isinstance(trainer, L.Trainer)
    assert model.num_classes == datamodule.dataset.num_classes
    assert model.hparams.input_size_px == cfg.data.input_size_px
    if experiment == "stanford_cars_12":
        assert datamodule.root.resolve() == stanford_root.resolve() and model.num_classes == 12
        assert cfg.model.backbone.pretrained == "imagenet"


def test_paper_experiment_is_googlenet_from_imagenet_with_aux_heads(tmp_path: Path):
    cfg = compose_config("train", ["experiment=paper_googlenet_compcars431", "data.root=/data/CompCars"], tmp_path)
    assert cfg.model.backbone.name == "googlenet" and cfg.model.backbone.pretrained == "imagenet"
    assert cfg.model.backbone.aux_logits and cfg.model.aux_loss_weight == 0.3
    assert cfg.data.roi_enlarge_fraction == 0.10 and cfg.trainer.accelerator == "gpu"


@pytest.mark.parametrize("trainer", ["default", "cpu", "gpu", "ddp", "ddp_sim"])
def test_trainer_configs_compose(trainer: str, tmp_path: Path):
    cfg = compose_config("train", [f"trainer={trainer}"], tmp_path)
    assert cfg.trainer._target_ == "lightning.pytorch.Trainer"
    if trainer == "ddp":
        assert cfg.trainer.strategy == "ddp" and cfg.trainer.num_nodes == 1 and cfg.trainer.sync_batchnorm
    if trainer == "ddp_sim":
        assert (cfg.trainer.strategy, cfg.trainer.accelerator, cfg.trainer.devices) == ("ddp_spawn", "cpu", 2)
        trainer_obj = hydra.utils.instantiate(cfg.trainer, logger=False)
        assert trainer_obj.world_size == 2


@pytest.mark.parametrize("logger", ["csv", "tensorboard", "many_loggers"])
def test_logger_configs_instantiate(logger: str, tmp_path: Path):
    cfg = compose_config("train", [f"logger={logger}"], tmp_path)
    loggers = instantiate_loggers(cfg.logger)
    assert len(loggers) == (2 if logger == "many_loggers" else 1)


def test_eval_config_composes_with_a_checkpoint(tmp_path: Path):
    cfg = compose_config("eval", ["ckpt_path=/runs/x/checkpoints/last.ckpt"], tmp_path)
    assert cfg.ckpt_path == "/runs/x/checkpoints/last.ckpt"
    callbacks = instantiate_callbacks(cfg.callbacks)
    assert {type(c).__name__ for c in callbacks} == {"TQDMProgressBar", "Table1Writer"}


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_experiments_compose_for_evaluation(experiment: str, tmp_path: Path):
    cfg = compose_config("eval", [f"experiment={experiment}", "ckpt_path=run/last.ckpt", "data.root=/data"], tmp_path)
    assert cfg.data.root == "/data" and cfg.callbacks.table1.out_dir == f"{tmp_path.resolve()}/table1"


def test_the_objects_are_built_from_the_checked_settings(tiny_root: Path, tmp_path: Path):
    """The datamodule and the classifier are built from the checked dataclasses, not again from the config: a value
    changed in the dataclass is the one the objects hold, and the hyper-parameters are plain values."""
    cfg = compose_config("train", ["experiment=demo", f"data.root={tiny_root}"], tmp_path)
    data, model_params = check_train_config(cfg)
    data = dataclasses.replace(data, batch_size=3)
    model_params = dataclasses.replace(model_params, label_smoothing=0.05)
    datamodule, model = instantiate_data_and_model(data, model_params)
    assert cfg.data.batch_size != 3 and datamodule.hparams.batch_size == 3
    assert model.hparams.label_smoothing == 0.05 and isinstance(model.hparams.backbone, dict)
    assert isinstance(datamodule.hparams.augment, dict)
