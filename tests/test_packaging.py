"""A plain (not editable) install into a fresh virtual environment, run from a folder outside the
repository, finds its configs: the Hydra CLIs compose and run."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from vehloc.config import config_dir

PROJECT_ROOT = Path(__file__).resolve().parents[1]
COPY_IGNORED = (".git", ".venv", "demo_data", "logs", "outputs", "multirun", "build", "*.egg-info", "__pycache__",
                ".pytest_cache")


def packaged() -> set[str]:
    """The packages pyproject.toml lists for setuptools (a wheel holds only those)."""
    import tomllib

    return set(tomllib.loads((PROJECT_ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])


def test_every_config_group_is_packaged():
    """Each folder of conf/ (at any depth) is a data subpackage of vehloc.conf in pyproject.toml."""
    packages = packaged()
    root = config_dir()
    groups = {"vehloc.conf." + ".".join(p.relative_to(root).parts) for p in root.rglob("*")
              if p.is_dir() and "__pycache__" not in p.parts}
    assert "vehloc.conf.localize.roi" in groups and groups <= packages


def test_every_python_package_is_packaged():
    """Each folder of vehloc/ with an `__init__.py` is listed in pyproject.toml."""
    packages = packaged()
    found = {".".join(p.parent.relative_to(PROJECT_ROOT).parts) for p in (PROJECT_ROOT / "vehloc").rglob("__init__.py")}
    assert "vehloc.geometry" in found and found <= packages, sorted(found - packages)


@pytest.mark.slow
def test_a_non_editable_install_runs_the_hydra_clis_from_elsewhere(tmp_path: Path):
    source, wheels = tmp_path / "source", tmp_path / "wheels"
    shutil.copytree(PROJECT_ROOT, source, symlinks=True, ignore=shutil.ignore_patterns(*COPY_IGNORED))
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VEHLOC_ROOT")}
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation", "-w", str(wheels),
         str(source)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )
    assert build.returncode == 0, build.stderr[-2000:]
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False)
    python = env_dir / "bin" / "python"
    site = Path(subprocess.check_output([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], text=True).strip())
    install = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet", "--no-deps", "--no-index",
         *map(str, wheels.glob("vehloc-*.whl"))], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )
    assert install.returncode == 0, install.stderr[-2000:]
    # the dependencies come from this interpreter's site-packages, listed after the fresh one's (and only now:
    # pip would take the editable vehloc there for installed)
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    where = subprocess.run([str(python), "-c", "import vehloc.config as c; print(c.config_dir())"],
                           cwd=elsewhere, env=env, capture_output=True, text=True)
    assert str(site) in where.stdout, where.stdout + where.stderr

    def run(*command: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(env_dir / "bin" / command[0]), *command[1:]], cwd=elsewhere, env=env,
                              capture_output=True, text=True, timeout=600)

    job = run("vehloc-train", "--cfg", "job", "experiment=demo")
    assert job.returncode == 0 and "input_size_px: 112" in job.stdout, job.stderr[-2000:]
    scene = run("vehloc-scene", "scene=table2_close_0", "out=scene", "scene.empty_frames=2", "scene.drive_frames=2",
                "scene.stopped_frames=1")
    assert scene.returncode == 0, scene.stderr[-2000:]
    calibrate = run("vehloc-calibrate", "site=scene/site.yaml", "image=scene/video.avi", "hydra.run.dir=calibration")
    assert calibrate.returncode == 0, calibrate.stderr[-2000:]
    assert (elsewhere / "calibration" / "calibration.json").is_file() and "inliers" in calibrate.stdout
