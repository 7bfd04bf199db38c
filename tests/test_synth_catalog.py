"""The demo car catalog and the car meshes built from it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vehloc.data.specs import read_specs_csv, write_specs_csv
from vehloc.synth.body import PLATE_SIZE_MM, Material, build_car_mesh
from vehloc.synth.catalog import (
    BODY_TYPE_CODES,
    CATALOG,
    make_names,
    model_attributes,
    model_by_id,
    model_names,
    validate_model,
    vehicle_specs,
)

# The paper's Table 1: length, width, height (mm).
TABLE_1 = {
    ("BMW", "7 Series"): (5250, 1902, 1498),
    ("Mercedes-Benz", "R Series"): (5159, 1922, 1663),
    ("Mercedes-Benz", "S Series"): (5250, 1899, 1494),
    ("BMW", "X5"): (4909, 1938, 1772),
    ("Citroen", "C4L"): (4675, 1780, 1500),
    ("Lamborghini", "Gallardo"): (4345, 1900, 1165),
    ("Hyundai", "Elantra"): (4545, 1725, 1425),
    ("Porsche", "Panamera"): (5049, 1937, 1423),
    ("Honda", "Spirior"): (4840, 1850, 1465),
    ("Volvo", "C30"): (4266, 1782, 1447),
}


def test_catalog_holds_table_1_and_more_with_contiguous_ids() -> None:
    assert len(CATALOG) >= 12
    assert [m.model_id for m in CATALOG] == list(range(1, len(CATALOG) + 1))
    by_name = {(m.make, m.model): m for m in CATALOG}
    for key, dims in TABLE_1.items():
        model = by_name[key]
        assert (model.length_mm, model.width_mm, model.height_mm) == dims, key
    extra = [m for m in CATALOG if (m.make, m.model) not in TABLE_1]
    assert len(extra) >= 2
    assert all(m.wheelbase_mm > 0 for m in CATALOG)


def test_make_ids_follow_makes() -> None:
    make_of_id = {}
    id_of_make = {}
    for m in CATALOG:
        assert make_of_id.setdefault(m.make_id, m.make) == m.make
        assert id_of_make.setdefault(m.make, m.make_id) == m.make_id
    assert model_by_id(1).make_id == model_by_id(4).make_id  # BMW 7 Series and X5
    assert model_by_id(2).make_id == model_by_id(3).make_id  # Benz R and S
    assert make_names()[model_by_id(4).make_id - 1] == "BMW"
    assert model_names()[2] == "Mercedes-Benz S Series"


def test_every_model_is_consistent_and_types_span_body_styles() -> None:
    for m in CATALOG:
        assert validate_model(m) == [], m.name
        assert m.rear_overhang_mm > 0 and m.boot_length_mm >= 0
        assert -m.length_mm / 2 < m.rear_axle_x_mm < m.front_axle_x_mm < m.length_mm / 2
        assert len(m.palette) >= 4
    assert {"sedan", "suv", "sports", "hatchback", "pickup", "mpv"} <= {m.body_type for m in CATALOG}


def test_validate_model_reports_bad_parameters() -> None:
    from dataclasses import replace

    model = model_by_id(1)
    too_long = replace(model, shape=replace(model.shape, roof_length_mm=4000.0))
    assert any("exceed the overall length" in p for p in validate_model(too_long))
    wide_tyres = replace(model, track_rear_mm=1890.0)
    assert any("stick out" in p for p in validate_model(wide_tyres))


def test_look_alike_models_differ_in_details() -> None:
    bmw7, benz_s = model_by_id(1), model_by_id(3)
    assert abs(bmw7.length_mm - benz_s.length_mm) < 10 and abs(bmw7.width_mm - benz_s.width_mm) < 10
    a, b = bmw7.details, benz_s.details
    differences = [
        a.grille != b.grille,
        a.headlight != b.headlight,
        a.taillight != b.taillight,
        a.window_splits != b.window_splits,
        a.pillar != b.pillar,
    ]
    assert sum(differences) >= 4


def test_specs_and_attributes_rows(tmp_path: Path) -> None:
    specs = vehicle_specs()
    path = tmp_path / "specs.csv"
    write_specs_csv(path, specs)
    table = read_specs_csv(path)
    assert table.model_ids == [m.model_id for m in CATALOG]
    assert table[8].length_mm == 5049 and table[8].wheelbase_mm == 2950
    attributes = model_attributes()
    assert [a.model_id for a in attributes] == [m.model_id for m in CATALOG]
    assert {a.type_code for a in attributes} <= set(BODY_TYPE_CODES.values())
    assert attributes[5].type_code == BODY_TYPE_CODES["sports"] and attributes[5].seat_number == 2


def _signed_volume_mm3(vertices_by_face: list[np.ndarray]) -> float:
    volume = 0.0
    for points in vertices_by_face:
        area = 0.5 * np.cross(points, np.roll(points, -1, axis=0)).sum(axis=0)
        volume += float(points[0] @ area) / 3.0
    return volume


@pytest.mark.parametrize("model", CATALOG, ids=lambda m: m.name)
def test_mesh_has_the_real_dimensions_wheels_and_plates(model) -> None:
    mesh = build_car_mesh(model)
    surfaces = np.flatnonzero(mesh.layers == 0)
    body = [i for i in surfaces if mesh.materials[i] != Material.MIRROR]
    points = np.concatenate([mesh.face(i) for i in body])
    np.testing.assert_allclose(
        points.max(axis=0) - points.min(axis=0), [model.length_mm, model.width_mm, model.height_mm], atol=1.0
    )
    np.testing.assert_allclose(points.min(axis=0)[2], 0.0, atol=1e-6)  # tyres touch the ground

    # Outward-facing polygons enclose a positive volume of plausible size.
    volume_m3 = _signed_volume_mm3([mesh.face(i) for i in surfaces]) / 1e9
    box_m3 = model.length_mm * model.width_mm * model.height_mm / 1e9
    assert 0.45 * box_m3 < volume_m3 < 0.9 * box_m3
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-9)
    roof = [
        i
        for i in surfaces
        if mesh.materials[i] == Material.BODY and mesh.centroids_mm[i, 2] > model.height_mm - 5
    ]
    assert roof and all(mesh.normals[i, 2] > 0.9 for i in roof)

    tyres = [i for i in surfaces if mesh.materials[i] == Material.TYRE]
    centres = {}
    for i in tyres:
        c = mesh.centroids_mm[i]
        centres.setdefault((c[0] > 0, c[1] > 0), []).append(c)
    assert len(centres) == 4
    mean = {k: np.mean(v, axis=0) for k, v in centres.items()}
    np.testing.assert_allclose(mean[(True, True)][0] - mean[(False, True)][0], model.wheelbase_mm, atol=1.0)
    np.testing.assert_allclose(mean[(True, True)][1] - mean[(True, False)][1], model.track_front_mm, atol=1.0)
    np.testing.assert_allclose(
        mean[(False, True)][1] - mean[(False, False)][1], model.track_rear_mm, atol=1.0
    )
    np.testing.assert_allclose(mean[(True, True)][2], model.shape.wheel_radius_mm, atol=1.0)

    plates = [
        i for i in range(mesh.num_faces) if mesh.materials[i] == Material.PLATE_INK and mesh.layers[i] == 1
    ]
    assert sorted(np.sign(mesh.centroids_mm[plates, 0]).tolist()) == [-1.0, 1.0]
    for i in plates:
        extent = np.ptp(mesh.face(i), axis=0)
        np.testing.assert_allclose(extent[1:], PLATE_SIZE_MM, atol=1e-6)
        assert abs(abs(mesh.centroids_mm[i, 0]) - model.length_mm / 2) < 1e-6
