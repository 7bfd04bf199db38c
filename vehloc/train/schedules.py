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


def param_groups(
    named_params: Iterable[tuple[str, nn.Parameter]],
    head_prefixes: tuple[str, ...],
    lr_backbone: float,
    lr_head: float,
    weight_decay: float,
) -> list[dict]:
    """Four groups: backbone/head x decayed (weights) / not decayed (biases and normalisation)."""
    groups = {
        (is_head, decay): {"params": [], "lr": lr_head if is_head else lr_backbone,
                           "weight_decay": weight_decay if decay else 0.0}
        for is_head in (False, True) for decay in (False, True)
    }
    for name, param in named_params:
        if not param.requires_grad:
            continue
        is_head = any(name == p or name.startswith(p + ".") for p in head_prefixes)
        groups[(is_head, param.ndim > 1)]["params"].append(param)
    return [g for g in groups.values() if g["params"]]


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
