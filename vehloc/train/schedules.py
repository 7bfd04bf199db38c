"""Optimizers with separate backbone/head learning rates, and per-step warmup + cosine or step schedules."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import torch
from torch import nn

from vehloc.errors import VehlocError


def _warmup_factor(step: int, warmup_steps: int, start_factor: float) -> float:
    """Linear warmup from `start_factor` at step 0 to 1 at `warmup_steps`."""
    return start_factor + (1.0 - start_factor) * step / warmup_steps


@dataclass
class WarmupCosine:
    """LR factor: linear warmup from `start_factor` over `warmup_steps`, then cosine down to `min_factor`."""

    warmup_steps: int
    total_steps: int
    start_factor: float = 0.1
    min_factor: float = 0.0

    def __call__(self, step: int) -> float:
        if step < self.warmup_steps:
            return _warmup_factor(step, self.warmup_steps, self.start_factor)
        span = max(1, self.total_steps - self.warmup_steps)
        progress = min(1.0, (step - self.warmup_steps) / span)
        return self.min_factor + (1.0 - self.min_factor) * 0.5 * (1.0 + math.cos(math.pi * progress))


@dataclass
class WarmupStep:
    """LR factor: linear warmup from `start_factor`, then times `gamma` every `step_size` steps."""

    warmup_steps: int
    step_size: int
    gamma: float = 0.1
    start_factor: float = 0.1

    def __call__(self, step: int) -> float:
        if step < self.warmup_steps:
            return _warmup_factor(step, self.warmup_steps, self.start_factor)
        return self.gamma ** ((step - self.warmup_steps) // max(1, self.step_size))


def block_name(name: str) -> str:
    """The block of backbone parameter `name`: a top-level module (`net.conv1`), or an item of a top-level
    sequence (`net._blocks.3`, `net.layer1.0`)."""
    parts = name.split(".")
    return ".".join(parts[:3] if len(parts) > 3 and parts[2].isdigit() else parts[:2])


def _under_any(name: str, prefixes: tuple[str, ...]) -> bool:
    """Whether parameter `name` belongs to one of the modules `prefixes` (dotted names)."""
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def block_depths(names: list[str]) -> list[int]:
    """Depth of each backbone parameter, as the index of its block (`block_name`) in registration order."""
    blocks: dict[str, int] = {}
    return [blocks.setdefault(block_name(name), len(blocks)) for name in names]


def freeze_lowest_blocks(net: nn.Module, count: int, head_names: tuple[str, ...]) -> list[str]:
    """Stop training the `count` lowest blocks of `net`'s backbone (blocks as in `block_depths`, heads excluded);
    the names of the frozen blocks. VehlocError when the backbone has fewer blocks."""
    backbone = {f"net.{name}": param for name, param in net.named_parameters()
                if not _under_any(name, head_names)}
    blocks = list(dict.fromkeys(block_name(name) for name in backbone))
    if count > len(blocks):
        raise VehlocError(f"model.frozen_blocks: {count} is more than the backbone's {len(blocks)} blocks")
    frozen = blocks[:count]
    for name, param in backbone.items():
        if block_name(name) in frozen:
            param.requires_grad_(False)
    return [block.removeprefix("net.") for block in frozen]


def param_groups(
    named_params: Iterable[tuple[str, nn.Parameter]],
    head_prefixes: tuple[str, ...],
    lr_backbone: float,
    lr_head: float,
    weight_decay: float,
    layer_decay: float = 1.0,
) -> list[dict]:
    """Groups by learning rate x decayed (weights) / not decayed (biases and normalisation): the heads at
    `lr_head`, the backbone at `lr_backbone` times `layer_decay` for each block below its top block."""
    trainable = [(name, param) for name, param in named_params if param.requires_grad]
    is_head = [_under_any(name, head_prefixes) for name, _ in trainable]
    backbone_names = [name for (name, _), head in zip(trainable, is_head) if not head]
    depths = dict(zip(backbone_names, block_depths(backbone_names)))
    top = max(depths.values(), default=0)
    groups: dict[tuple[bool, float, bool], dict] = {}
    for (name, param), head in zip(trainable, is_head):
        lr = lr_head if head else lr_backbone * layer_decay ** (top - depths[name])
        decay = param.ndim > 1
        group = groups.setdefault((head, lr, decay), {"params": [], "lr": lr,
                                                      "weight_decay": weight_decay if decay else 0.0})
        group["params"].append(param)
    return list(groups.values())


def build_optimizer(groups: list[dict], name: str, momentum: float = 0.9, nesterov: bool = False,
                    betas: tuple[float, float] = (0.9, 0.999)) -> torch.optim.Optimizer:
    """`sgd` (momentum, optional Nesterov) or `adamw` over the given parameter groups."""
    if name == "sgd":
        return torch.optim.SGD(groups, lr=groups[0]["lr"], momentum=momentum, nesterov=nesterov)
    if name == "adamw":
        return torch.optim.AdamW(groups, lr=groups[0]["lr"], betas=tuple(betas))
    raise VehlocError(f"model.optimizer.name {name!r} is not one of sgd, adamw")


def build_schedule(name: str, total_steps: int, steps_per_epoch: int, warmup_epochs: float = 0.0,
                   step_epochs: float = 10.0, gamma: float = 0.1, min_factor: float = 0.0
                   ) -> WarmupCosine | WarmupStep | None:
    """The LR factor function of schedule `name` (`cosine`, `step` or `none`), in optimizer steps."""
    warmup_steps = round(warmup_epochs * steps_per_epoch)
    if name == "cosine":
        return WarmupCosine(warmup_steps, total_steps, min_factor=min_factor)
    if name == "step":
        return WarmupStep(warmup_steps, max(1, round(step_epochs * steps_per_epoch)), gamma)
    if name == "none":
        return None
    raise VehlocError(f"model.scheduler.name {name!r} is not one of cosine, step, none")
