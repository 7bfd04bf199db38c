"""The key-point geometry of the paper's placement against exact ground truth from a pinhole camera: a
horizontal line at a height mapped to the road and lowered back, O below the plate, the bumper's height from
a shape."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.keypoints import below_plate_mm, end_bottom_height_mm, lowered_line_mm


@pytest.fixture(scope="module")
def camera() -> PinholeCamera:
    return PinholeCamera.look_at(np.array([1500.0, -2000.0, 6500.0]), np.array([0.0, 12000.0, 0.0]), 1000.0, 1280, 720)


def _road_line_through(points_mm: np.ndarray) -> np.ndarray:
    line = np.cross([*points_mm[0], 1.0], [*points_mm[1], 1.0])
    return line / np.hypot(line[0], line[1])


@pytest.mark.parametrize("height_mm", [0.0, 185.0, 450.0])
def test_a_line_at_a_height_mapped_to_the_road_is_lowered_onto_the_line_below_it(camera: PinholeCamera,
                                                                                   height_mm: float) -> None:
    """A horizontal 3D line at `height_mm`, imaged and mapped to the road by the homography, lowered: the road
    line straight below it (both its points within 1e-6 mm)."""
    below = np.array([[-900.0, 9000.0], [1100.0, 9300.0]])
    image_px = camera.project(np.c_[below, np.full(2, height_mm)])
    as_if_on_road = camera.road_to_image().inverse(image_px)
    lowered = lowered_line_mm(_road_line_through(as_if_on_road), height_mm, camera.centre_mm)
    assert np.abs(below @ lowered[:2] + lowered[2]).max() / np.hypot(*lowered[:2]) < 1e-6


def test_o_is_the_footprint_point_below_the_plate(camera: PinholeCamera) -> None:
    """The plate's middle 450 mm above (300, 9000), mapped to the road as if on it, and the front line through
    (300, 9000): O is (300, 9000) within 1e-6 mm."""
    plate_px = camera.project(np.array([[300.0, 9000.0, 450.0]]))
    p_mm = camera.road_to_image().inverse(plate_px)[0]
    front_line = _road_line_through(np.array([[-700.0, 9000.0], [1300.0, 9000.0]]))
    np.testing.assert_allclose(below_plate_mm(p_mm, front_line, camera.centre_mm[:2]), [300.0, 9000.0], atol=1e-6)


def test_the_end_bottom_height_is_the_lowest_point_near_that_end() -> None:
    nose = np.array([[2000.0, -800, 300], [2000, 800, 300], [2100, -800, 320], [2100, 800, 320], [1900, 0, 900]])
    tail = np.array([[-2100.0, -800, 250], [-2100, 800, 250], [-2000, 0, 800]])
    shape = VehicleShape((np.vstack([nose, tail]),))
    assert end_bottom_height_mm(shape, "front") == 300.0
    assert end_bottom_height_mm(shape, "rear") == 250.0
    assert end_bottom_height_mm(shape, None) == 275.0
