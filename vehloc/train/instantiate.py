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
from hydra.errors import InstantiationException
from lightning.pytorch.loggers import Logger
from lightning.pytorch.utilities import rank_zero_info, rank_zero_only, rank_zero_warn
from omegaconf import DictConfig, OmegaConf, open_dict

from vehloc.atomic import write_text
from vehloc.config import ConfigError, config_dir
from vehloc.data.compcars import CompCarsSet
from vehloc.data.specs import SpecsTable
from vehloc.errors import VehlocError
from vehloc.hardware import cpu_info
from vehloc.train.datamodule import CompCarsDataModule
from vehloc.train.module import LitVehicleClassifier
from vehloc.train.params import DataParams, ModelParams
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


def instantiate(config: Any, where: str, **kwargs: Any) -> Any:
    """`hydra.utils.instantiate`, with the error of the object's constructor as one line: a VehlocError raised
    inside (a missing weights file, an unreadable checkpoint) as it is, anything else as ConfigError naming the
    config group `where`, not wrapped in Hydra's report."""
    try:
        return hydra.utils.instantiate(config, **kwargs)
    except InstantiationException as err:
        cause = err.__cause__
        while isinstance(cause, InstantiationException) and cause.__cause__ is not None:
            cause = cause.__cause__
        if isinstance(cause, VehlocError):
            raise cause from None
        reason = str(cause).splitlines()[0] if cause is not None and str(cause) else str(err).splitlines()[-1]
        raise ConfigError(f"{where}: cannot build {config.get('_target_', 'it')} ({reason})") from None


def _instantiate_group(group: DictConfig | None, kind: str) -> list[Any]:
    if not group:
        return []
    if not isinstance(group, DictConfig):
        raise VehlocError(f"{kind} config must be a mapping of named entries")
    entries = [(name, entry) for name, entry in group.items() if isinstance(entry, DictConfig) and "_target_" in entry]
    return [instantiate(entry, f"{kind}.{name}") for name, entry in entries]


def run_trainer(trainer: L.Trainer, method: str, *args: Any, **kwargs: Any) -> Any:
    """`trainer.fit` / `trainer.test` (by `method`) with Ctrl-C raised as KeyboardInterrupt: Lightning catches
    it, shuts the run down (the last complete checkpoint stays) and exits with code 1, which the console
    scripts then report as `<prog>: interrupted` and exit code 130."""
    try:
        return getattr(trainer, method)(*args, **kwargs)
    except SystemExit:
        if trainer.interrupted:
            raise KeyboardInterrupt from None
        raise


def instantiate_callbacks(cfg: DictConfig | None) -> list[L.Callback]:
    return _instantiate_group(cfg, "callbacks")


def instantiate_loggers(cfg: DictConfig | None) -> list[Logger]:
    return _instantiate_group(cfg, "logger")


def instantiate_data_and_model(
    data: DataParams, model_params: ModelParams, data_read: tuple[CompCarsSet, SpecsTable] | None = None,
) -> tuple[CompCarsDataModule, LitVehicleClassifier]:
    """The datamodule (data set and specs validated; `data_read`: those already read from its root by
    `vehloc.train.classes.read_data`) and a model built for its classes, from the checked settings
    (`check_train_config`); validation and test images go through the model's preprocessing."""
    datamodule = CompCarsDataModule.from_params(data)
    if data_read is not None:
        datamodule.use_data(*data_read)
    model = LitVehicleClassifier.from_params(model_params, **datamodule.class_info())
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
    return instantiate(cfg.trainer, "trainer", precision=choice.resolved, callbacks=callbacks, logger=loggers or False)


@rank_zero_only
def write_device_record(choice: PrecisionChoice, run_dir: Path) -> Path:
    """`device.json` in the run folder: the precision asked for and resolved, the device, torch and threads."""
    record = {"precision": choice.as_dict(), "torch": torch.__version__, "torch_threads": torch.get_num_threads(),
              "cpu": cpu_info().model_name, "cpu_flags": cpu_info().reported_flags}
    return write_text(run_dir / "device.json", json.dumps(record, indent=2) + "\n")


def log_hyperparameters(cfg: DictConfig, loggers: list[Logger]) -> None:
    """Send the resolved run config to every logger."""
    config = OmegaConf.to_container(cfg, resolve=True)
    for logger in loggers:
        logger.log_hyperparams(config)
