"""Vehicle specs table: validation, lookup, and the MATLAB names and attributes files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vehloc.data.attributes import ModelAttributes, read_attributes, write_attributes
from vehloc.data.matfile import read_make_model_names, write_make_model_names
from vehloc.data.specs import VehicleSpec, display_name, read_specs_csv, write_specs_csv
from vehloc.errors import DataError

HEADER = "model_id,make,model,length_mm,width_mm,height_mm,wheelbase_mm\n"


def test_real_specs_table(stanford_root: Path) -> None:
    specs = read_specs_csv(stanford_root / "specs.csv")
    assert len(specs) == 12
    assert specs[12].model == "smart fortwo Convertible"
    np.testing.assert_array_equal(specs.dims_mm([1, 12]), [[4624, 1811, 1413], [2695, 1560, 1565]])
    assert specs[2].wheelbase_mm == 3198


def test_round_trip(tmp_path: Path) -> None:
    rows = [VehicleSpec(3, "BMW", "BMW 7 Series", 5250, 1902, 1498, 3070), VehicleSpec(7, "X", "Y", 4000, 1700, 1500)]
    write_specs_csv(tmp_path / "s.csv", rows)
    specs = read_specs_csv(tmp_path / "s.csv")
    assert [specs[3], specs[7]] == rows
    assert specs[7].wheelbase_mm is None


def test_every_bad_value_named_with_line(tmp_path: Path) -> None:
    path = tmp_path / "s.csv"
    path.write_text(
        HEADER
        + "1,A,a,4500,1800,1450,2700\n"
        + "2,B,b,-4500,1800,1450,\n"
        + "x,C,c,4500,1800,1450,\n"
        + "1,D,d,4500,1800,1450,\n"
        + "4,E,e,4500,wide,0,\n"
        + "5,F,f,4500,1800,1450,4600\n"
    )
    with pytest.raises(DataError) as info:
        read_specs_csv(path)
    problems = info.value.problems
    assert problems == [
        f"{path}:3: length_mm '-4500' must be positive",
        f"{path}:4: model_id 'x' is not a positive integer",
        f"{path}:5: model_id 1 already given on line 2",
        f"{path}:6: width_mm 'wide' is not a number",
        f"{path}:6: height_mm '0' must be positive",
        f"{path}:7: wheelbase_mm 4600 is not shorter than length_mm 4500",
    ]


def test_missing_column_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "s.csv"
    path.write_text("model_id,make,model,length_mm,width_mm\n1,A,a,1,1\n")
    with pytest.raises(DataError, match="missing column\\(s\\) height_mm"):
        read_specs_csv(path)
    with pytest.raises(DataError, match="specs table does not exist"):
        read_specs_csv(tmp_path / "none.csv")


def test_require_lists_every_missing_class(tiny_root: Path) -> None:
    specs = read_specs_csv(tiny_root / "specs.csv")
    specs.require([11, 12, 25])
    with pytest.raises(DataError) as info:
        specs.require([11, 40, 41, 25], names={40: "Delta"})
    assert "no dimensions for 2 class(es)" in info.value.summary
    assert info.value.problems == ["model 40 (Delta)", "model 41"]


def test_make_model_names_round_trip_and_fixed_bytes(tmp_path: Path) -> None:
    write_make_model_names(tmp_path / "a.mat", ["BMW", "Benz"], ["7 Series", "", "S Series"])
    write_make_model_names(tmp_path / "b.mat", ["BMW", "Benz"], ["7 Series", "", "S Series"])
    assert (tmp_path / "a.mat").read_bytes() == (tmp_path / "b.mat").read_bytes()
    makes, models = read_make_model_names(tmp_path / "a.mat")
    assert makes == {1: "BMW", 2: "Benz"}
    assert models == {1: "7 Series", 3: "S Series"}


def test_attributes_round_trip_and_errors(tmp_path: Path) -> None:
    rows = [ModelAttributes(5, 250, 3.0, 4, 5, 3), ModelAttributes(9, 0, 0, 2, 2, 9)]
    write_attributes(tmp_path / "attributes.txt", rows)
    assert read_attributes(tmp_path / "attributes.txt") == {5: rows[0], 9: rows[1]}
    bad = tmp_path / "bad.txt"
    bad.write_text("model_id maximum_speed displacement door_number seat_number type\n5 250 3.0 4 5\n")
    with pytest.raises(DataError) as info:
        read_attributes(bad)
    assert info.value.problems == [f"{bad}:2: expected 6 fields model_id maximum_speed displacement door_number seat_number type, got 5"]


def test_display_name_says_the_make_once():
    assert display_name("Honda", "Honda Spirior") == "Honda Spirior"  # the demo catalog's models start with the make
    assert display_name("BMW", "X5") == "BMW X5"
    assert display_name("", "Golf") == "Golf"
