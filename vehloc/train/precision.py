"""The trainer's numeric precision, chosen for the device: `auto` is bf16 autocast only where the hardware
computes bfloat16 natively and fp32 elsewhere, since emulated bf16 on a CPU is several times slower."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from vehloc.hardware import CpuInfo, cpu_info

AUTO = "auto"
BF16_PRECISIONS = ("bf16-mixed", "bf16-true", "bf16")


@dataclass(frozen=True)
class PrecisionChoice:
    """The precision asked for, the one the trainer runs with, why, and on what device."""

    requested: str
    resolved: str
    reason: str
    device: str
    warning: str | None = None

    def describe(self) -> str:
        """One line for the log and the reports."""
        asked = f" (asked: {self.requested})" if self.requested != self.resolved else ""
        return f"precision {self.resolved}{asked} on {self.device}: {self.reason}"

    def as_dict(self) -> dict[str, str | None]:
        return {"requested": self.requested, "resolved": self.resolved, "reason": self.reason,
                "device": self.device, "warning": self.warning}


def uses_gpu(accelerator: str) -> bool:
    """Whether a Lightning `accelerator` setting trains on a CUDA GPU."""
    return accelerator in ("gpu", "cuda") or (accelerator == AUTO and torch.cuda.is_available())


def device_description(gpu: bool) -> str:
    """The GPU's name, or the CPU's model name, cores and flags."""
    if gpu:
        return torch.cuda.get_device_name() if torch.cuda.is_available() else "GPU"
    return cpu_info().describe()


def resolve_precision(requested: str | int, accelerator: str, cpu: CpuInfo | None = None) -> PrecisionChoice:
    """The Lightning precision to train with for `requested` (`auto` or any Lightning value) on
    `accelerator`. On a CPU, `auto` is `bf16-mixed` with native bf16 and `32-true` without; on a GPU it is
    `bf16-mixed` where the GPU supports it, else `16-mixed`. A bf16 precision asked for on a CPU without
    native bf16 is kept, with a warning."""
    requested = str(requested)
    if uses_gpu(accelerator):
        device = device_description(gpu=True)
        if requested != AUTO:
            return PrecisionChoice(requested, requested, "as configured", device)
        if torch.cuda.is_available() and torch.cuda.is_bf16_supported():
            return PrecisionChoice(requested, "bf16-mixed", "the GPU computes bf16", device)
        return PrecisionChoice(requested, "16-mixed", "the GPU has no bf16; fp16 with loss scaling", device)
    cpu = cpu or cpu_info()
    device = cpu.describe()
    if requested == AUTO:
        if cpu.native_bf16:
            return PrecisionChoice(requested, "bf16-mixed", "the CPU computes bf16 natively", device)
        return PrecisionChoice(requested, "32-true", "the CPU has no native bf16 (emulated bf16 is slower)", device)
    if requested in BF16_PRECISIONS and not cpu.native_bf16:
        warning = (f"trainer.precision={requested} on {cpu.model_name}, which has no native bf16 (no avx512_bf16 "
                   "or amx_bf16): bf16 is emulated and several times slower than fp32; trainer.precision=auto "
                   "picks fp32 here")
        return PrecisionChoice(requested, requested, "as configured", device, warning)
    return PrecisionChoice(requested, requested, "as configured", device)
