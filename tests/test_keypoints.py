"""The key-point geometry of the paper's placement against exact ground truth from a pinhole camera: a
horizontal line at a height mapped to the road and lowered back, O below the plate, the heading from the
plate's edges, the bumper's height from a shape."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vehloc.config import ConfigError
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.keypoints import (
    DetectorParams,
    below_plate_mm,
    end_bottom_height_mm,
    lowered_line_mm,
    plate_length_heading_deg,
    plate_width_heading_deg,
)
from vehloc.geometry.plate import Plate


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


def _plate_seen(camera: PinholeCamera, heading_deg: float) -> Plate:
    """The image of a 440 x 140 mm plate 300-440 mm above the road on the end of a vehicle whose length axis
    runs along `heading_deg`, its middle at (300, 9000)."""
    across = np.array([-np.sin(np.radians(heading_deg)), np.cos(np.radians(heading_deg))])
    corners_mm = [np.r_[np.array([300.0, 9000.0]) + s * 220.0 * across, z]
                  for s, z in ((-1, 440.0), (1, 440.0), (1, 300.0), (-1, 300.0))]
    corners_px = camera.project(np.array(corners_mm))

    def line(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        homogeneous = np.cross([*a, 1.0], [*b, 1.0])
        return homogeneous / np.hypot(*homogeneous[:2])

    return Plate(corners_px, corners_px.mean(axis=0), line(*corners_px[:2]), line(*corners_px[2:]), 1.0)


@pytest.mark.parametrize("heading_deg", [90.0, 60.0, 120.0, 0.0])
def test_the_plates_edges_give_the_length_axis(camera: PinholeCamera, heading_deg: float) -> None:
    """The plate's upper and lower edges, imaged at their heights and mapped to the road as if on it, run
    across the length axis: the heading within 1e-6 deg."""
    plate = _plate_seen(camera, heading_deg)
    width_deg = plate_width_heading_deg(plate, camera.road_to_image())
    assert abs((width_deg - heading_deg - 90.0 + 90.0) % 180.0 - 90.0) < 1e-6


def test_the_plates_heading_is_kept_only_when_the_body_agrees(camera: PinholeCamera) -> None:
    """Within the agreement the plate's heading wins; beyond it the footprint's stands."""
    plate = _plate_seen(camera, 93.0)
    road_to_image = camera.road_to_image()
    assert plate_length_heading_deg(plate, road_to_image, 90.0, 5.0) == pytest.approx(93.0, abs=1e-6)
    assert plate_length_heading_deg(plate, road_to_image, 80.0, 5.0) == 80.0


def test_the_end_bottom_height_is_the_lowest_point_near_that_end() -> None:
    nose = np.array([[2000.0, -800, 300], [2000, 800, 300], [2100, -800, 320], [2100, 800, 320], [1900, 0, 900]])
    tail = np.array([[-2100.0, -800, 250], [-2100, 800, 250], [-2000, 0, 800]])
    shape = VehicleShape((np.vstack([nose, tail]),))
    assert end_bottom_height_mm(shape, "front") == 300.0
    assert end_bottom_height_mm(shape, "rear") == 250.0
    assert end_bottom_height_mm(shape, None) == 275.0


def test_a_heading_agreement_out_of_range_is_named_before_any_work() -> None:
    defaults = DetectorParams.from_config()
    groups = {name: dataclasses.asdict(getattr(defaults, name)) for name in ("footprint", "plate", "wheels")}
    groups["plate"]["heading_agreement_deg"] = -1.0
    with pytest.raises(ConfigError, match=r"plate\.heading_agreement_deg: must be in \[0, 90\], got -1.0"):
        DetectorParams.from_mapping(groups)
