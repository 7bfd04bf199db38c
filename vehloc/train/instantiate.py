"""Building the run's objects from the Hydra config: data, model, callbacks, loggers, trainer."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import hydra
import lightning as L
import torch
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from lightning.pytorch.loggers import Logger
from lightning.pytorch.utilities import rank_zero_info, rank_zero_only, rank_zero_warn
from omegaconf import DictConfig, OmegaConf, open_dict

from vehloc.config import config_dir
from vehloc.errors import VehlocError
from vehloc.hardware import cpu_info
from vehloc.train.datamodule import CompCarsDataModule
from vehloc.train.module import LitVehicleClassifier
from vehloc.train.precision import PrecisionChoice, resolve_precision



def compose_config(config_name: str, overrides: Sequence[str] = (), output_dir: str | Path = ".") -> DictConfig:
    """Compose `conf/<config_name>.yaml` with overrides outside a Hydra app (notebooks, tests), with
    `paths.output_dir` as the run folder."""
    with initialize_config_dir(version_base="1.3", config_dir=str(config_dir()), job_name=config_name):
        cfg = compose(config_name, overrides=list(overrides), return_hydra_config=True)
    HydraConfig.instance().set_config(cfg)
    with open_dict(cfg):
        cfg.paths.output_dir = str(Path(output_dir).resolve())
        del cfg["hydra"]
    return cfg


def _instantiate_group(group: DictConfig | None, kind: str) -> list[Any]:
    if not group:
        return []
    if not isinstance(group, DictConfig):
        raise VehlocError(f"{kind} config must be a mapping of named entries")
    entries = [entry for entry in group.values() if isinstance(entry, DictConfig) and "_target_" in entry]
    return [hydra.utils.instantiate(entry) for entry in entries]


def instantiate_callbacks(cfg: DictConfig | None) -> list[L.Callback]:
    return _instantiate_group(cfg, "callbacks")


def instantiate_loggers(cfg: DictConfig | None) -> list[Logger]:
    return _instantiate_group(cfg, "logger")


def instantiate_data_and_model(cfg: DictConfig) -> tuple[CompCarsDataModule, LitVehicleClassifier]:
    """The datamodule (data set and specs validated) and a model built for its classes; validation and test
    images go through the model's preprocessing."""
    if OmegaConf.is_missing(cfg.data, "root") or cfg.data.root is None:
        raise VehlocError("data.root=PATH is required: a CompCars-format data set")
    datamodule: CompCarsDataModule = hydra.utils.instantiate(cfg.data, _convert_="all")
    model: LitVehicleClassifier = hydra.utils.instantiate(cfg.model, **datamodule.class_info(), _convert_="all")
    datamodule.use_preprocessing(model.preprocessing)
    return datamodule, model


def instantiate_trainer(cfg: DictConfig, callbacks: list[L.Callback], loggers: list[Logger]) -> L.Trainer:
    """The trainer, with `trainer.precision` resolved for the device (`auto`: bf16 only where it is native);
    the choice is printed in one line and written to `device.json` in the run folder."""
    choice = resolve_precision(cfg.trainer.get("precision", "32-true"), str(cfg.trainer.get("accelerator", "auto")))
    if choice.warning:
        rank_zero_warn(choice.warning)
    rank_zero_info(choice.describe())
    write_device_record(choice, Path(cfg.paths.output_dir))
    return hydra.utils.instantiate(cfg.trainer, precision=choice.resolved, callbacks=callbacks,
                                   logger=loggers or False)


@rank_zero_only
def write_device_record(choice: PrecisionChoice, run_dir: Path) -> Path:
    """`device.json` in the run folder: the precision asked for and resolved, the device, torch and threads."""
    record = {"precision": choice.as_dict(), "torch": torch.__version__, "torch_threads": torch.get_num_threads(),
              "cpu": cpu_info().model_name, "cpu_flags": cpu_info().reported_flags}
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / "device.json"
    temp = path.with_name(f".{path.name}.tmp")
    temp.write_text(json.dumps(record, indent=2) + "\n")
    temp.replace(path)
    return path


def log_hyperparameters(cfg: DictConfig, loggers: list[Logger]) -> None:
    """Send the resolved run config to every logger."""
    config = OmegaConf.to_container(cfg, resolve=True)
    for logger in loggers:
        logger.log_hyperparams(config)
