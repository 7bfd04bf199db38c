"""The settings of `vehloc-train` and `vehloc-eval` checked at the door, before the data is read, a network is
built or Lightning is imported: every value of the data and model groups against its type and range (typed
dataclasses built with `vehloc.config.build_params`), the trainer's settings that vehloc relies on, and the
top-level ones. A bad value is one `ConfigError` line naming the setting, e.g.
`data.batch_size: expected an integer, got 'abc'` or `trainer.max_epochs: must be >= 1, got -1`.

Torch-free on purpose: a typo is answered in a second, not after the deep-learning stack has loaded."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from vehloc.config import ConfigError, SettingError, build_params, check_choice, check_range

BACKBONE_NAMES = (
    "googlenet", "resnet50", "efficientnet_b0", "convnext_tiny", "efficientnet_lite0", "efficientnet_lite1",
    "efficientnet_lite2",
)
"""The backbones of `vehloc.train.backbones.RECIPES` (a test holds the two lists equal)."""
OPTIMIZERS = ("sgd", "adamw")
SCHEDULES = ("cosine", "step", "none")
MIN_INPUT_SIZE_PX = 32
"""The smallest network input: the backbones halve their input five times."""
MAX_SEED = 2**32 - 1
ACCELERATORS = ("cpu", "gpu", "cuda", "mps", "tpu", "auto")
PRECISIONS = ("auto", "64-true", "64", "32-true", "32", "16-mixed", "16", "bf16-mixed", "bf16", "16-true",
              "bf16-true", "transformer-engine", "transformer-engine-float16")


@dataclass(frozen=True)
class AugmentParams:
    """`data.augment`: the random resized crop, flip and colour jitter of training."""

    crop_scale: tuple[float, float]
    crop_ratio: tuple[float, float]
    hflip: bool
    color_jitter: float

    def __post_init__(self) -> None:
        low, high = self.crop_scale
        if not 0 < low <= high <= 1:
            raise SettingError("crop_scale", f"expected [low, high] with 0 < low <= high <= 1, got {list(self.crop_scale)}")
        low, high = self.crop_ratio
        if not 0 < low <= high:
            raise SettingError("crop_ratio", f"expected [low, high] with 0 < low <= high, got {list(self.crop_ratio)}")
        check_range("color_jitter", self.color_jitter, 0.0, 1.0)


@dataclass(frozen=True)
class DataParams:
    """`data`: the CompCars-format root, the ROI and input size, augmentation, batches and loaders."""

    root: str | None
    specs_csv: str | None
    input_size_px: int
    eval_resize_px: int | None
    roi_enlarge_fraction: float
    keep_aspect: bool
    augment: AugmentParams
    batch_size: int
    eval_batch_size: int | None
    num_workers: int
    pin_memory: bool
    balanced_sampling: bool
    val_fraction: float
    select_on_test: bool
    seed: int | None

    def __post_init__(self) -> None:
        check_range("input_size_px", self.input_size_px, MIN_INPUT_SIZE_PX)
        if self.eval_resize_px is not None and self.eval_resize_px < self.input_size_px:
            raise SettingError(
                "eval_resize_px", f"must be >= input_size_px ({self.input_size_px}) or null, got {self.eval_resize_px}")
        check_range("roi_enlarge_fraction", self.roi_enlarge_fraction, 0.0, 1.0)
        check_range("batch_size", self.batch_size, 1)
        if self.eval_batch_size is not None:
            check_range("eval_batch_size", self.eval_batch_size, 1)
        check_range("num_workers", self.num_workers, 0)
        check_range("val_fraction", self.val_fraction, 0.0, 1.0, high_open=True)
        if self.select_on_test and self.val_fraction > 0:
            raise SettingError("select_on_test", f"true validates on the test split: set val_fraction=0, not {self.val_fraction}")
        if not self.select_on_test and self.val_fraction == 0:
            raise SettingError("val_fraction", "0 would choose the checkpoint on the test split: give a share of train "
                                               "(e.g. 0.1), or set data.select_on_test=true to do so knowingly")
        if self.seed is not None:
            check_range("seed", self.seed, 0, MAX_SEED)


@dataclass(frozen=True)
class BackboneParams:
    """`model.backbone`: which network and its starting weights."""

    name: str
    pretrained: str
    aux_logits: bool
    dropout: float

    def __post_init__(self) -> None:
        check_choice("name", self.name, BACKBONE_NAMES)
        check_range("dropout", self.dropout, 0.0, 1.0, high_open=True)
        if self.pretrained not in ("imagenet", "none"):
            path = Path(self.pretrained)
            if not path.is_file():
                state = "is a folder" if path.is_dir() else "no such file"
                raise SettingError("pretrained", f"imagenet, none or the path of a state dict; {self.pretrained}: {state}")


@dataclass(frozen=True)
class OptimizerParams:
    """`model.optimizer`."""

    name: str
    lr_backbone: float
    lr_head: float
    weight_decay: float
    momentum: float = 0.9
    nesterov: bool = False
    betas: tuple[float, float] = (0.9, 0.999)

    def __post_init__(self) -> None:
        check_choice("name", self.name, OPTIMIZERS)
        check_range("lr_backbone", self.lr_backbone, 0.0)
        check_range("lr_head", self.lr_head, 0.0, low_open=True)
        check_range("weight_decay", self.weight_decay, 0.0)
        check_range("momentum", self.momentum, 0.0, 1.0, high_open=True)
        for beta in self.betas:
            check_range("betas", beta, 0.0, 1.0, high_open=True)


@dataclass(frozen=True)
class SchedulerParams:
    """`model.scheduler`: the learning-rate schedule per optimizer step."""

    name: str
    warmup_epochs: float = 0.0
    min_factor: float = 0.0
    step_epochs: float = 10.0
    gamma: float = 0.1

    def __post_init__(self) -> None:
        check_choice("name", self.name, SCHEDULES)
        check_range("warmup_epochs", self.warmup_epochs, 0.0)
        check_range("min_factor", self.min_factor, 0.0, 1.0)
        check_range("step_epochs", self.step_epochs, 0.0, low_open=True)
        check_range("gamma", self.gamma, 0.0, 1.0, low_open=True)


@dataclass(frozen=True)
class ModelParams:
    """`model`: the classifier (its preprocessing settings come from `data`)."""

    backbone: BackboneParams
    optimizer: OptimizerParams
    scheduler: SchedulerParams
    aux_loss_weight: float
    label_smoothing: float
    channels_last: bool
    expected_top_k: int
    input_size_px: int
    eval_resize_px: int | None
    roi_enlarge_fraction: float
    keep_aspect: bool
    flip_average: bool = False
    freeze_bn_stats: bool = False
    layer_decay: float = 1.0
    mixup_alpha: float = 0.0
    frozen_blocks: int = 0

    def __post_init__(self) -> None:
        check_range("frozen_blocks", self.frozen_blocks, 0)
        check_range("aux_loss_weight", self.aux_loss_weight, 0.0)
        check_range("label_smoothing", self.label_smoothing, 0.0, 1.0, high_open=True)
        check_range("expected_top_k", self.expected_top_k, 1)
        check_range("layer_decay", self.layer_decay, 0.0, 1.0, low_open=True)
        check_range("mixup_alpha", self.mixup_alpha, 0.0)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _integer_at_least(low: int) -> Callable[[Any], str | None]:
    return lambda v: None if _is_int(v) and v >= low else f"expected an integer >= {low}, got {v!r}"


def _batches_limit(value: Any) -> str | None:
    if _is_int(value) and value >= 0:
        return None
    if isinstance(value, float) and 0.0 <= value <= 1.0:
        return None
    return f"expected a number of batches (an integer >= 0) or a share of them (0.0 to 1.0), got {value!r}"


def _devices(value: Any) -> str | None:
    if value == "auto" or (_is_int(value) and (value >= 1 or value == -1)):
        return None
    if isinstance(value, (list, tuple)) and value and all(_is_int(v) and v >= 0 for v in value):
        return None
    if isinstance(value, str) and value.replace(",", "").replace(" ", "").lstrip("-").isdigit():
        return None
    return f"expected auto, a number of devices (>= 1, -1 for all) or a list of device indices, got {value!r}"


TRAINER_RULES: dict[str, Callable[[Any], str | None]] = {
    "max_epochs": _integer_at_least(1),
    "min_epochs": lambda v: None if v is None or (_is_int(v) and v >= 0) else f"expected an integer >= 0, got {v!r}",
    "max_steps": _integer_at_least(-1),
    "accelerator": lambda v: None if v in ACCELERATORS else f"expected one of {', '.join(ACCELERATORS)}, got {v!r}",
    "devices": _devices,
    "num_nodes": _integer_at_least(1),
    "precision": lambda v: None if str(v) in PRECISIONS else f"expected one of {', '.join(PRECISIONS)}, got {v!r}",
    "check_val_every_n_epoch": lambda v: None if v is None or (_is_int(v) and v >= 1)
    else f"expected an integer >= 1 or null, got {v!r}",
    "log_every_n_steps": _integer_at_least(1),
    "accumulate_grad_batches": _integer_at_least(1),
    "gradient_clip_val": lambda v: None if v is None or (_is_number(v) and v >= 0)
    else f"expected a number >= 0 or null, got {v!r}",
    "deterministic": lambda v: None if v in (True, False, "warn") else f"expected true, false or warn, got {v!r}",
    "fast_dev_run": lambda v: None if isinstance(v, bool) or (_is_int(v) and v >= 0)
    else f"expected true, false or a number of batches, got {v!r}",
    "limit_train_batches": _batches_limit,
    "limit_val_batches": _batches_limit,
    "limit_test_batches": _batches_limit,
    "overfit_batches": _batches_limit,
    "detect_anomaly": lambda v: None if isinstance(v, bool) else f"expected true or false, got {v!r}",
}


def _container(cfg: DictConfig, key: str) -> Any:
    """The resolved plain value of `cfg[key]`; ConfigError naming the key when an interpolation fails."""
    try:
        node = cfg[key]
        return OmegaConf.to_container(node, resolve=True) if isinstance(node, DictConfig) else node
    except OmegaConfBaseException as err:
        first = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ConfigError(f"{key}: {first}") from None


def _settings(values: Mapping[str, Any]) -> dict[str, Any]:
    """A group's settings without Hydra's `_target_`-style keys."""
    return {k: v for k, v in values.items() if not str(k).startswith("_")}


def check_trainer(cfg: DictConfig) -> None:
    """ConfigError naming the first trainer setting of the wrong type or range (the keys vehloc relies on;
    others are left to Lightning)."""
    values = _container(cfg, "trainer")
    if not isinstance(values, Mapping):
        raise ConfigError(f"trainer: expected a mapping of settings, got {values!r}")
    for key, rule in TRAINER_RULES.items():
        if key in values:
            problem = rule(values[key])
            if problem:
                raise ConfigError(f"trainer.{key}: {problem}")
    low, high = values.get("min_epochs"), values.get("max_epochs")
    if _is_int(low) and _is_int(high) and low > high:
        raise ConfigError(f"trainer.min_epochs: {low} is more than trainer.max_epochs ({high})")


def check_data(cfg: DictConfig) -> DataParams:
    """The data settings, checked; ConfigError naming the first bad one."""
    if OmegaConf.is_missing(cfg.data, "root") or cfg.data.get("root") is None:
        raise ConfigError("data.root=PATH is required: a CompCars-format data set")
    return build_params(DataParams, _settings(_container(cfg, "data")), "data")


def check_top_level(cfg: DictConfig) -> None:
    seed = cfg.get("seed")
    if seed is not None and not (_is_int(seed) and 0 <= seed <= MAX_SEED):
        raise ConfigError(f"seed: expected an integer from 0 to {MAX_SEED} or null, got {seed!r}")
    for key in ("train", "test"):
        if key in cfg and not isinstance(cfg[key], bool):
            raise ConfigError(f"{key}: expected true or false, got {cfg[key]!r}")
    ckpt_path = cfg.get("ckpt_path") if not OmegaConf.is_missing(cfg, "ckpt_path") else None
    if ckpt_path is not None and not isinstance(ckpt_path, str):
        raise ConfigError(f"ckpt_path: expected the path of a checkpoint, got {ckpt_path!r}")


def check_train_config(cfg: DictConfig) -> tuple[DataParams, ModelParams]:
    """Every setting `vehloc-train` relies on, checked before any work; ConfigError naming the first bad one."""
    check_top_level(cfg)
    data = check_data(cfg)
    model = build_params(ModelParams, _settings(_container(cfg, "model")), "model")
    check_trainer(cfg)
    if cfg.get("train", True) is False and cfg.get("test", True) is False:
        raise ConfigError("train=false and test=false: nothing to do")
    return data, model


def check_eval_config(cfg: DictConfig) -> DataParams:
    """Every setting `vehloc-eval` relies on (the network and its preprocessing come from the checkpoint),
    checked before any work; ConfigError naming the first bad one."""
    onnx_path = cfg.get("onnx_path")
    if onnx_path is not None and not isinstance(onnx_path, str):
        raise ConfigError(f"onnx_path: expected the path of an ONNX model, got {onnx_path!r}")
    has_checkpoint = not OmegaConf.is_missing(cfg, "ckpt_path") and bool(cfg.get("ckpt_path"))
    if has_checkpoint == bool(onnx_path):
        raise ConfigError("give ckpt_path= or onnx_path=, not both" if onnx_path else
                          "ckpt_path=PATH is required: the checkpoint to evaluate (or onnx_path=MODEL.onnx: an export)")
    check_top_level(cfg)
    data = check_data(cfg)
    check_trainer(cfg)
    return data
