"""The one box convention (0-based, half-open) and its conversions to and from the file conventions."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.boxes import Box


@pytest.mark.parametrize("label", [(1, 1, 1, 1), (3, 2, 38, 29), (597, 12, 1024, 768)])
def test_compcars_label_round_trip(label: tuple[int, int, int, int]):
    """CompCars labels are 1-based and inclusive: `1 1 1 1` is the top-left pixel alone."""
    box = Box.from_compcars_label(*label)
    assert box.to_compcars_label() == label
    assert box.width_px == label[2] - label[0] + 1 and box.height_px == label[3] - label[1] + 1


@pytest.mark.parametrize("inclusive", [(0, 0, 0, 0), (2, 1, 37, 28), (100, 50, 639, 479)])
def test_scene_ground_truth_round_trip(inclusive: tuple[int, int, int, int]):
    """The scene ground truth is 0-based and inclusive: `0 0 0 0` is the top-left pixel alone."""
    box = Box.from_inclusive(*inclusive)
    assert box.to_inclusive() == inclusive and box.area_px == (inclusive[2] - inclusive[0] + 1) * (inclusive[3] - inclusive[1] + 1)


def test_the_same_pixels_in_all_three_conventions():
    mask = np.zeros((30, 40), bool)
    mask[1:29, 2:38] = True  # rows 1..28, columns 2..37
    box = Box.tight(mask)
    assert box == Box(2, 1, 38, 29)
    assert box.to_compcars_label() == (3, 2, 38, 29) and box.to_inclusive() == (2, 1, 37, 28)
    assert box.crop(mask).all() and box.crop(mask).shape == (28, 36)
    assert Box.tight(np.zeros((3, 3), bool)) is None


def test_enlarging_grows_each_side_and_clips_to_the_image():
    assert Box(100, 50, 200, 150).enlarged(0.10, 640, 480) == Box(90, 40, 210, 160)
    assert Box(2, 1, 38, 29).enlarged(0.10, 40, 30) == Box(0, 0, 40, 30)
    assert Box(10, 10, 20, 20).enlarged(0.0, 40, 30) == Box(10, 10, 20, 20)


def test_overlap_centre_and_border():
    a, b = Box(0, 0, 10, 10), Box(5, 0, 15, 10)
    assert a.iou(b) == pytest.approx(50 / 150) and a.iou(Box(20, 20, 30, 30)) == 0.0
    np.testing.assert_allclose(Box(0, 0, 10, 4).centre_px, [4.5, 1.5])  # pixel centres 0..9 and 0..3
    assert Box(0, 5, 10, 10).touches_border(100, 100) and not Box(1, 1, 99, 99).touches_border(100, 100)
    assert Box(1, 1, 99, 99).touches_border(100, 100, margin_px=1)
    with pytest.raises(ValueError, match="lies outside the 40x30 image"):
        Box(50, 50, 60, 60).crop(np.zeros((30, 40)))


def test_shifted_moves_into_a_crop_and_back():
    box, crop = Box(30, 40, 90, 75), Box(20, 25, 200, 150)
    inside = box.shifted(-crop.x0, -crop.y0)
    assert inside == Box(10, 15, 70, 50) and inside.shifted(crop.x0, crop.y0) == box
    assert inside.width_px == box.width_px and inside.height_px == box.height_px
