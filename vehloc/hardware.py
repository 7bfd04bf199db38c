"""What processor this runs on: its model name, its instruction-set flags and whether it computes bfloat16
natively. Read from the operating system (no torch), so that every timing can name its CPU."""

from __future__ import annotations

import os
import platform
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

# x86 flags of native bfloat16 arithmetic (AVX-512 BF16, AMX tiles) and the Arm feature of the same
NATIVE_BF16_FLAGS = ("avx512_bf16", "amx_bf16", "bf16")
# x86 flags of 8-bit integer dot products (VNNI, AMX) and the Arm dot-product features: where INT8 inference pays
INT8_DOT_PRODUCT_FLAGS = ("avx512_vnni", "avx_vnni", "amx_int8", "asimddp", "i8mm")
# flags worth printing beside a timing: the vector width and the low-precision units
REPORTED_FLAGS = ("avx2", "fma", "avx512f", "avx512_vnni", "avx_vnni", "avx512_bf16", "amx_tile", "amx_bf16", "amx_int8",
                  "asimd", "sve", "bf16")


@dataclass(frozen=True)
class CpuInfo:
    """The processor: `model_name` as `lscpu` prints it, its feature flags and logical core count."""

    model_name: str
    flags: frozenset[str]
    logical_cores: int
    machine: str

    @property
    def native_bf16(self) -> bool:
        """True when the CPU has bfloat16 arithmetic units; elsewhere bf16 autocast is emulated (and slower)."""
        return any(flag in self.flags for flag in NATIVE_BF16_FLAGS)

    @property
    def int8_dot_product(self) -> bool:
        """True when the CPU has 8-bit integer dot products (VNNI, AMX, Arm dot product): INT8 models run on
        them; without, x86's u8 x s8 multiply can saturate (onnxruntime's `reduce_range`) and gains little."""
        return any(flag in self.flags for flag in INT8_DOT_PRODUCT_FLAGS)

    @property
    def reported_flags(self) -> list[str]:
        return [flag for flag in REPORTED_FLAGS if flag in self.flags]

    def describe(self) -> str:
        """One line: model name, cores, the flags that matter and whether bf16 is native."""
        flags = " ".join(self.reported_flags) or "none of " + " ".join(REPORTED_FLAGS)
        bf16 = "native bf16" if self.native_bf16 else "no native bf16"
        vnni = "int8 dot products (VNNI)" if self.int8_dot_product else "no int8 dot products (no VNNI)"
        return f"{self.model_name} ({self.logical_cores} logical cores; {flags}; {bf16}; {vnni})"


def parse_cpuinfo(text: str) -> tuple[str, frozenset[str]]:
    """Model name and flags of the first processor in a Linux `/proc/cpuinfo` text (x86 `flags`, Arm
    `Features`)."""
    name, flags = "", frozenset()
    for line in text.splitlines():
        key, sep, value = line.partition(":")
        if not sep:
            continue
        key = key.strip().lower()
        if key in ("model name", "hardware", "cpu model") and not name:
            name = value.strip()
        elif key in ("flags", "features") and not flags:
            flags = frozenset(value.split())
    return name, flags


@lru_cache(maxsize=1)
def cpu_info() -> CpuInfo:
    """This machine's processor (Linux: `/proc/cpuinfo`; elsewhere the platform's name and no flags)."""
    cpuinfo = Path("/proc/cpuinfo")
    name, flags = parse_cpuinfo(cpuinfo.read_text(errors="replace")) if cpuinfo.is_file() else ("", frozenset())
    return CpuInfo(
        model_name=name or platform.processor() or platform.machine() or "unknown CPU",
        flags=flags,
        logical_cores=os.cpu_count() or 1,
        machine=platform.machine(),
    )
