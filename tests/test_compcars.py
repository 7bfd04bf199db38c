"""CompCars-format reader and validator, on a tiny generated root and on the real 12-model set."""

from __future__ import annotations

from pathlib import Path

import pytest

from vehloc.data.boxes import Box
from vehloc.data.compcars import (
    check_images,
    parse_label,
    read_compcars,
    scan_compcars,
)
from vehloc.errors import DataError


def test_reads_tiny_root(tiny_root: Path) -> None:
    data = read_compcars(tiny_root)
    assert data.model_ids == (11, 12, 25)
    assert len(data.train) == 9 and len(data.test) == 3
    assert data.labels("test") == [0, 1, 2]
    assert data.class_index(25) == 2
    assert data.model_names[25] == "Gamma" and 13 not in data.model_names
    assert data.make_names == {1: "MakeOne", 2: "MakeTwo"}
    assert data.attributes[12].type_code == 3
    sample = data.test[0]
    assert sample.viewpoint == 4
    assert sample.box == Box(2, 1, 38, 29) and sample.box.to_compcars_label() == (3, 2, 38, 29)
    assert [row["model"] for row in data.class_table()] == ["Alpha", "Beta", "Gamma"]


def test_reads_real_stanford_set(stanford_root: Path) -> None:
    data = read_compcars(stanford_root)
    assert data.num_classes == 12
    assert (len(data.train), len(data.test)) == (366, 138)
    assert len({s.make_id for s in data.train}) == 11
    assert data.model_names[12] == "smart fortwo Convertible"
    assert all(s.viewpoint == -1 for s in data.train)
    assert check_images(data.test) == []


def test_missing_root_is_one_problem(tmp_path: Path) -> None:
    result = scan_compcars(tmp_path / "nowhere")
    assert result.dataset is None
    assert result.problems == [f"{tmp_path / 'nowhere'}: data root does not exist or is not a folder"]


def test_missing_split_file(tiny_root: Path) -> None:
    (tiny_root / "train_test_split/classification/test.txt").unlink()
    with pytest.raises(DataError) as info:
        read_compcars(tiny_root)
    assert any("test.txt: split list missing" in p for p in info.value.problems)


def test_every_problem_named_with_file_and_line(tiny_root: Path) -> None:
    (tiny_root / "image/1/11/2015/img1.jpg").unlink()
    (tiny_root / "label/1/12/2015/img0.txt").write_text("4\n1\n3 2 38\n")
    (tiny_root / "label/2/25/2015/img2.txt").unlink()
    split = tiny_root / "train_test_split/classification/test.txt"
    split.write_text(split.read_text() + "9/99/2015/x.jpg\nnot-a-path\n")
    (tiny_root / "image/9/99/2015").mkdir(parents=True)
    (tiny_root / "image/9/99/2015/x.jpg").write_bytes(b"")
    (tiny_root / "label/9/99/2015").mkdir(parents=True)
    (tiny_root / "label/9/99/2015/x.txt").write_text("1\n1\n1 1 2 2\n")
    problems = scan_compcars(tiny_root).problems
    text = "\n".join(problems)
    assert "train.txt:2: image" in text and "img1.jpg missing" in text
    assert "label/1/12/2015/img0.txt: malformed label: line 3" in text
    assert "label/2/25/2015/img2.txt missing" in text
    assert "test.txt:5: expected 'make_id/model_id/year/name.jpg'" in text
    assert "model 99 (9/99/2015/x.jpg) is absent from train" in text
    assert len(problems) == 5


def test_unreadable_image_found_on_demand(tiny_root: Path) -> None:
    (tiny_root / "image/1/11/2015/img3.jpg").write_bytes(b"not a jpeg")
    data = read_compcars(tiny_root)  # existence is checked at every start, decoding only on demand
    problems = check_images(data.train + data.test)
    assert problems == [f"{tiny_root / 'image/1/11/2015/img3.jpg'}: not a readable image"]


def test_box_outside_image_reported(tiny_root: Path) -> None:
    (tiny_root / "label/1/11/2015/img0.txt").write_text("1\n1\n1 1 41 30\n")
    data = read_compcars(tiny_root)
    problems = check_images(data.train)
    assert len(problems) == 1 and "box 1 1 41 30 leaves the 40x30 image" in problems[0]


def test_duplicate_and_overlapping_lines(tiny_root: Path) -> None:
    split_dir = tiny_root / "train_test_split/classification"
    train = split_dir / "train.txt"
    first = train.read_text().splitlines()[0]
    train.write_text(train.read_text() + first + "\n")
    (split_dir / "test.txt").write_text((split_dir / "test.txt").read_text() + first + "\n")
    text = "\n".join(scan_compcars(tiny_root).problems)
    assert f"train.txt:10: {first} listed twice" in text
    assert f"{first} is listed in both train and test" in text


def test_corrupt_names_file(tiny_root: Path) -> None:
    (tiny_root / "misc/make_model_name.mat").write_bytes(b"garbage")
    problems = scan_compcars(tiny_root).problems
    assert len(problems) == 1 and "make_model_name.mat: not a readable MATLAB file" in problems[0]


def test_missing_names_file_is_a_warning(tiny_root: Path) -> None:
    (tiny_root / "misc/make_model_name.mat").unlink()
    result = scan_compcars(tiny_root)
    assert result.problems == [] and "make_model_name.mat: missing" in result.warnings[0]
    assert result.dataset.model_name_of(11) == "model 11"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "expected 3 lines"),
        ("x\n1\n1 1 2 2", "line 1: viewpoint must be an integer"),
        ("7\n1\n1 1 2 2", "line 1: viewpoint 7 not in"),
        ("1\n2\n1 1 2 2", "line 2: declares 2 box(es)"),
        ("1\n1\n1 1 2", "line 3: expected 4 integers"),
        ("1\n1\n5 1 2 2", "line 3: box 5 1 2 2 is not a 1-based box"),
        ("1\n1\n0 1 2 2", "is not a 1-based box"),
    ],
)
def test_malformed_labels(text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        parse_label(text)


def test_label_with_uncertain_viewpoint() -> None:
    assert parse_label("-1\n1\n1 1 597 333\n") == (-1, Box(0, 0, 597, 333))
