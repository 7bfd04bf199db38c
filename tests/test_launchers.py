"""The cluster launchers (`conf/launchers/hydra/launcher/`): `hydra/launcher=slurm` and `hydra/launcher=ray_cluster`
compose for every tool that sweeps (vehloc-train, vehloc-eval, vehloc-localize) on top of the plugins' own schemas,
and keep the tools' settings; the SLURM one needs hydra-submitit-launcher (a dev dependency), the Ray one
hydra-ray-launcher (`vehloc[cluster]`: its cloudpickle<3 pin conflicts with joblib's, so it is not in dev)."""

from __future__ import annotations

import importlib.util

import pytest
from hydra import compose, initialize_config_dir

from vehloc.config import config_dir

TOOLS = {  # config folder, config name, the required settings
    "vehloc-train": ("", "train", []),
    "vehloc-eval": ("", "eval", ["ckpt_path=x.ckpt"]),
    "vehloc-localize": ("localize", "localize", ["video=a.avi", "calibration=c.json", "model=m.onnx"]),
}
RAY = importlib.util.find_spec("hydra_plugins.hydra_ray_launcher") is not None


def _hydra_config(tool: str, launcher: str, *overrides: str):
    folder, name, required = TOOLS[tool]
    with initialize_config_dir(version_base="1.3", config_dir=str(config_dir() / folder), job_name=name):
        cfg = compose(name, overrides=[*required, f"hydra/launcher={launcher}", *overrides], return_hydra_config=True)
    return cfg


@pytest.mark.parametrize("tool", TOOLS)
def test_slurm_launcher_composes_over_submitits_schema(tool: str) -> None:
    cfg = _hydra_config(tool, "slurm", "hydra.launcher.partition=cpu", "hydra.launcher.timeout_min=30")
    launcher = cfg.hydra.launcher
    assert launcher._target_ == "hydra_plugins.hydra_submitit_launcher.submitit_launcher.SlurmLauncher"
    assert (launcher.partition, launcher.timeout_min, launcher.cpus_per_task, launcher.mem_gb) == ("cpu", 30, 4, 16)
    assert launcher.array_parallelism == 64 and launcher.qos is None  # the plugin's own fields are there too
    assert cfg.task_name == TOOLS[tool][1]


def test_slurm_launcher_refuses_a_misspelt_field() -> None:
    from hydra.errors import ConfigCompositionException

    with pytest.raises(ConfigCompositionException, match="partitoin"):
        _hydra_config("vehloc-localize", "slurm", "hydra.launcher.partitoin=cpu")


@pytest.mark.skipif(not RAY, reason="hydra-ray-launcher is not installed (pip install 'vehloc[cluster]')")
@pytest.mark.parametrize("tool", TOOLS)
def test_ray_launcher_composes_over_rays_schema(tool: str) -> None:
    cfg = _hydra_config(tool, "ray_cluster", "hydra.launcher.ray.init.address=auto")
    launcher = cfg.hydra.launcher
    assert launcher._target_ == "hydra_plugins.hydra_ray_launcher.ray_launcher.RayLauncher"
    assert launcher.ray.init.address == "auto" and launcher.ray.remote.num_cpus == 2
