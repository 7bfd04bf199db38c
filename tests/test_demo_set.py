"""The CompCars-format demo set: layout round trip, tight boxes, true viewpoints, determinism."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from vehloc.data.compcars import read_compcars
from vehloc.data.specs import read_specs_csv
from vehloc.errors import VehlocError
from vehloc.synth.catalog import CATALOG, model_by_id
from vehloc.synth.contact_sheet import CELL_PX, LABEL_WIDTH_PX, write_contact_sheet
from vehloc.synth.demo_set import (
    IMAGE_SIZE_PX,
    make_demo_set,
    render_scene,
    sample_scene,
    split_indices,
    viewpoint_code,
)

PER_MODEL = 4


def _tree_bytes(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def demo_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_demo_set(tmp_path_factory.mktemp("demo") / "compcars", per_model=PER_MODEL, seed=3, workers=2)


@pytest.mark.parametrize(
    ("azimuth_deg", "code"),
    [
        (0, 1),
        (22.4, 1),
        (22.6, 4),
        (-30, 4),
        (45, 4),
        (90, 3),
        (270, 3),
        (-100, 3),
        (135, 5),
        (210, 5),
        (170, 2),
        (180, 2),
        (-160, 2),
    ],
)
def test_viewpoint_codes(azimuth_deg: float, code: int) -> None:
    assert viewpoint_code(azimuth_deg) == code


def _camera_elevation_deg(scene) -> float:
    offset = scene.camera.centre_mm - np.array([scene.pose.x_mm, scene.pose.y_mm, 0.0])
    return float(np.degrees(np.arctan2(offset[2], np.linalg.norm(offset[:2]))))


def test_traffic_views_see_fronts_and_rears_from_above_and_any_views_go_all_round() -> None:
    model = model_by_id(9)
    traffic = [sample_scene(model, 0, i, views="traffic") for i in range(120)]
    codes = {scene.viewpoint for scene in traffic}
    assert {1, 2} <= codes <= {1, 2, 4, 5}
    for scene in traffic:
        off_axis_deg = abs((scene.azimuth_deg + 90.0) % 180.0 - 90.0)  # from the nearer of front and rear
        assert off_axis_deg <= 30.0 + 1e-6
        # the camera aims above the ground, so the elevation of its centre seen from the footprint centre
        # is at least the drawn 8 deg
        assert _camera_elevation_deg(scene) >= 8.0
    around = {sample_scene(model, 0, i, views="any").viewpoint for i in range(120)}
    assert around == {1, 2, 3, 4, 5}
    with pytest.raises(ValueError, match="views"):
        sample_scene(model, 0, 0, views="aerial")


def test_layout_reads_back_with_every_model_in_both_splits(demo_root: Path) -> None:
    dataset = read_compcars(demo_root)
    assert dataset.model_ids == tuple(m.model_id for m in CATALOG)
    assert len(dataset.train) + len(dataset.test) == PER_MODEL * len(CATALOG)
    for m in CATALOG:
        in_train = [s for s in dataset.train if s.model_id == m.model_id]
        in_test = [s for s in dataset.test if s.model_id == m.model_id]
        assert len(in_train) == 3 and len(in_test) == 1, m.name
        assert {s.make_id for s in in_train + in_test} == {m.make_id}
        assert dataset.model_name_of(m.model_id) == m.name
        assert dataset.make_name_of(m.make_id) == m.make
        assert dataset.attributes[m.model_id].type_code == m.type_code
    specs = read_specs_csv(demo_root / "specs.csv")
    specs.require(dataset.model_ids)
    assert specs[6].height_mm == 1165


def test_labels_hold_the_true_viewpoint_and_the_tight_box(demo_root: Path) -> None:
    dataset = read_compcars(demo_root)
    width, height = IMAGE_SIZE_PX
    for sample in dataset.train + dataset.test:
        image = cv2.imread(str(sample.image_path))
        assert image is not None and image.shape == (height, width, 3)
        x0, y0, x1, y1 = sample.box.as_tuple()
        assert 0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height
        index = int(Path(sample.rel_path).stem)
        scene = sample_scene(model_by_id(sample.model_id), 3, index)
        render = render_scene(scene)
        assert render.box is not None
        np.testing.assert_allclose(sample.box.as_tuple(), render.box.as_tuple(), atol=1)
        # The car is whole in the frame: its box does not touch the border.
        assert not sample.box.touches_border(width, height)
        # Viewpoint from where the camera really is relative to the car's front.
        heading = np.radians(scene.pose.heading_deg)
        to_camera = scene.camera.centre_mm[:2] - np.array([scene.pose.x_mm, scene.pose.y_mm])
        azimuth = np.degrees(np.arctan2(to_camera[1], to_camera[0]) - heading)
        assert sample.viewpoint == viewpoint_code(float(azimuth))


def test_same_seed_same_bytes_whatever_the_workers(demo_root: Path, tmp_path: Path) -> None:
    again = make_demo_set(tmp_path / "again", per_model=PER_MODEL, seed=3, workers=1)
    reference = _tree_bytes(demo_root)
    # images and labels, plus the marker, specs, attributes, model names, vehicle shapes and two splits
    assert len(reference) == 2 * PER_MODEL * len(CATALOG) + 7
    assert _tree_bytes(again) == reference
    other = make_demo_set(tmp_path / "other", per_model=2, seed=4, workers=1)
    other_bytes = _tree_bytes(other)
    image = "image/1/1/2013/0000.jpg"
    assert other_bytes[image] != reference[image]


def test_split_indices_are_stratified() -> None:
    train, test = split_indices(0, 5, 60, 0.25)
    assert len(test) == 15 and len(train) == 45 and not set(train) & set(test)
    assert split_indices(0, 5, 60, 0.25) == (train, test)
    for fraction in (0.01, 0.99):
        train, test = split_indices(0, 5, 2, fraction)
        assert len(train) == 1 and len(test) == 1 and set(train) | set(test) == {0, 1}


def test_rewrites_its_own_folder_but_not_a_foreign_one(tmp_path: Path) -> None:
    root = make_demo_set(tmp_path / "demo", per_model=2, seed=0, workers=1)
    stale = root / "image" / "1" / "1" / "2013" / "9999.jpg"
    stale.write_bytes(b"old")
    make_demo_set(root, per_model=2, seed=0, workers=1)
    assert not stale.exists()
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(VehlocError, match="not a vehloc demo set"):
        make_demo_set(foreign, per_model=2, workers=1)
    assert (foreign / "notes.txt").read_text() == "keep me"
    with pytest.raises(ValueError, match="per_model"):
        make_demo_set(tmp_path / "tiny", per_model=1, workers=1)


def test_contact_sheet_has_a_row_per_model(demo_root: Path, stanford_root: Path, tmp_path: Path) -> None:
    for root, per_model in ((demo_root, 4), (stanford_root, 3)):
        out = write_contact_sheet(root, tmp_path / f"sheet_{root.name}.png", per_model=per_model)
        sheet = cv2.imread(str(out))
        assert sheet.shape == (12 * CELL_PX[1], LABEL_WIDTH_PX + per_model * CELL_PX[0], 3)
        first_cell = sheet[: CELL_PX[1], LABEL_WIDTH_PX : LABEL_WIDTH_PX + CELL_PX[0]]
        assert first_cell.std() > 10  # an image, not the blank fill
