"""Shared fixtures: paths to the real data beside the project, a tiny CompCars-format root and the benchmark's low
verge camera."""

from __future__ import annotations

import os
import shutil
from pathlib import Path


def _share_the_cores_between_workers() -> None:
    """Under pytest-xdist each worker, and every process it starts, gets its share of the cores for the math
    libraries' threads (OpenMP: torch's): two workers each running as many threads as there are cores made the
    training and export tests a third slower on 2 cores. A value already set is kept."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if workers > 1:
        os.environ.setdefault("OMP_NUM_THREADS", str(max(1, (os.cpu_count() or 1) // workers)))


_share_the_cores_between_workers()  # before anything imports torch

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from vehloc.data.attributes import ModelAttributes, write_attributes  # noqa: E402
from vehloc.data.boxes import Box  # noqa: E402
from vehloc.data.compcars import write_label, write_split_list  # noqa: E402
from vehloc.data.matfile import write_make_model_names  # noqa: E402
from vehloc.data.specs import VehicleSpec, write_specs_csv  # noqa: E402
from vehloc.geometry.camera import PinholeCamera  # noqa: E402

PROJECT_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = PROJECT_ROOT.parent / "shared" / "data"
LOW_VERGE = PinholeCamera.look_at([6000.0, 0.0, 5000.0], [0.0, 9000.0, 0.0], 600.0, 1280, 720)
"""The localization benchmark's low camera: 5 m high on the right verge, a wide lens (f 600 px) looking down the road;
a car 30-38 m away fills an ROI 104-148 px wide."""


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.fail(f"real data missing: {SHARED_DATA} (the project expects ../shared/data beside it)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def stanford_root() -> Path:
    root = SHARED_DATA / "stanford_cars_12"
    if not root.is_dir():
        pytest.fail(f"real data set missing: {root} (see shared/data/README.md)")
    return root


def write_tiny_compcars(root: Path) -> Path:
    """Three models of two makes, 3 train + 1 test image each, 40x30 px coloured images."""
    models = {11: 1, 12: 1, 25: 2}  # model id -> make id
    train, test = [], []
    for model_id, make_id in models.items():
        for i in range(4):
            rel = f"{make_id}/{model_id}/2015/img{i}.jpg"
            image = np.full((30, 40, 3), (40 * i, 80, model_id * 5), dtype=np.uint8)
            (root / "image" / rel).parent.mkdir(parents=True, exist_ok=True)
            cv2.imwrite(str(root / "image" / rel), image)
            write_label((root / "label" / rel).with_suffix(".txt"), 4, Box.from_compcars_label(3, 2, 38, 29))
            (test if i == 3 else train).append(rel)
    split_dir = root / "train_test_split" / "classification"
    write_split_list(split_dir / "train.txt", train)
    write_split_list(split_dir / "test.txt", test)
    model_names = [""] * 25
    model_names[10], model_names[11], model_names[24] = "Alpha", "Beta", "Gamma"
    write_make_model_names(root / "misc" / "make_model_name.mat", ["MakeOne", "MakeTwo"], model_names)
    write_attributes(
        root / "misc" / "attributes.txt",
        [ModelAttributes(m, 200, 2.0, 4, 5, 3) for m in models],
    )
    write_specs_csv(
        root / "specs.csv",
        [
            VehicleSpec(11, "MakeOne", "Alpha", 4500, 1800, 1450, 2700),
            VehicleSpec(12, "MakeOne", "Beta", 4600, 1850, 1470, None),
            VehicleSpec(25, "MakeTwo", "Gamma", 4000, 1700, 1600, 2500),
        ],
    )
    return root


@pytest.fixture
def tiny_root(tmp_path: Path) -> Path:
    return write_tiny_compcars(tmp_path / "tiny")


@pytest.fixture
def stanford_copy(tmp_path: Path, stanford_root: Path) -> Path:
    """A writable copy of the real set, for breaking it on purpose."""
    copy = tmp_path / "stanford_copy"
    shutil.copytree(stanford_root, copy)
    for path in copy.rglob("*"):
        path.chmod(0o755 if path.is_dir() else 0o644)
    return copy


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files with slow tests first, each file's tests in their order: pytest-xdist hands whole files to the
    workers as they free up, so the long ones start early and the workers end together."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_files)
