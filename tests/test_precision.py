"""Precision that fits the CPU: the CPU's flags read from /proc/cpuinfo, `auto` resolved to bf16 only where
bf16 is native, a warning for emulated bf16, and the choice recorded in the run folder."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vehloc.hardware import CpuInfo, cpu_info, parse_cpuinfo
from vehloc.train.instantiate import compose_config, instantiate_trainer
from vehloc.train.precision import resolve_precision

INTEL_SAPPHIRE_RAPIDS = """processor\t: 0
vendor_id\t: GenuineIntel
model name\t: Intel(R) Xeon(R) Platinum 8481C CPU @ 2.70GHz
flags\t\t: fpu sse2 avx avx2 fma avx512f avx512_vnni avx512_bf16 amx_bf16 amx_tile amx_int8
processor\t: 1
model name\t: Intel(R) Xeon(R) Platinum 8481C CPU @ 2.70GHz
"""
AMD_ZEN3 = """processor\t: 0
vendor_id\t: AuthenticAMD
model name\t: AMD EPYC 7B13
flags\t\t: fpu sse2 avx avx2 fma bmi2 sha_ni vaes
"""
ARM_GRAVITON3 = """processor\t: 0
BogoMIPS\t: 2100.00
Features\t: fp asimd evtstrm aes sve bf16 i8mm
CPU implementer\t: 0x41
"""


def cpu(text: str) -> CpuInfo:
    name, flags = parse_cpuinfo(text)
    return CpuInfo(name or "Arm", flags, 2, "x86_64")


def test_cpuinfo_is_parsed_for_intel_amd_and_arm():
    name, flags = parse_cpuinfo(INTEL_SAPPHIRE_RAPIDS)
    assert name == "Intel(R) Xeon(R) Platinum 8481C CPU @ 2.70GHz" and {"avx512_bf16", "amx_bf16"} <= flags
    assert cpu(INTEL_SAPPHIRE_RAPIDS).native_bf16
    assert parse_cpuinfo(AMD_ZEN3)[0] == "AMD EPYC 7B13" and not cpu(AMD_ZEN3).native_bf16
    assert cpu(ARM_GRAVITON3).native_bf16 and "sve" in cpu(ARM_GRAVITON3).reported_flags
    assert "no native bf16" in cpu(AMD_ZEN3).describe() and "AMD EPYC 7B13" in cpu(AMD_ZEN3).describe()


@pytest.mark.parametrize(("text", "expected"), [(INTEL_SAPPHIRE_RAPIDS, "bf16-mixed"), (AMD_ZEN3, "32-true")])
def test_auto_is_bf16_only_where_the_cpu_computes_it(text: str, expected: str):
    choice = resolve_precision("auto", "cpu", cpu(text))
    assert choice.resolved == expected and choice.requested == "auto" and choice.warning is None
    assert expected in choice.describe() and parse_cpuinfo(text)[0] in choice.describe()


def test_explicit_bf16_on_a_cpu_without_it_runs_as_asked_with_a_warning():
    choice = resolve_precision("bf16-mixed", "cpu", cpu(AMD_ZEN3))
    assert choice.resolved == "bf16-mixed"
    assert "emulated" in choice.warning and "AMD EPYC 7B13" in choice.warning and "\n" not in choice.warning
    assert resolve_precision("bf16-mixed", "cpu", cpu(INTEL_SAPPHIRE_RAPIDS)).warning is None
    assert resolve_precision("32-true", "cpu", cpu(AMD_ZEN3)).resolved == "32-true"


@pytest.mark.parametrize("experiment", ["demo", "finetune_cpu", "stanford_cars_12"])
def test_the_lite0_experiments_train_in_fp32_on_any_cpu(experiment: str, tmp_path: Path):
    """bf16 autocast slowed Lite0's steps even where bf16 is native (README, Precision): they ask for fp32."""
    cfg = compose_config("train", [f"experiment={experiment}", "data.root=unused"], tmp_path)
    assert cfg.trainer.precision == "32-true"
    assert instantiate_trainer(cfg, [], []).precision == "32-true"


def test_the_scratch_experiment_resolves_auto_for_this_cpu_and_records_it(tmp_path: Path):
    cfg = compose_config("train", ["experiment=demo_googlenet_scratch", "data.root=unused"], tmp_path)
    assert cfg.trainer.precision == "auto"
    trainer = instantiate_trainer(cfg, [], [])
    expected = "bf16-mixed" if cpu_info().native_bf16 else "32-true"
    assert trainer.precision == expected
    record = json.loads((tmp_path / "device.json").read_text())
    assert record["precision"]["requested"] == "auto" and record["precision"]["resolved"] == expected
    assert record["cpu"] == cpu_info().model_name
