"""The heading of a moving vehicle from its path (`pipeline.heading_from_motion`), and the model fit's start
without key points (`pipeline.fit_from_travel`): the footprint's nearest point is the
road point under the box's bottom, the centre lies half the footprint's extent beyond it along the line of
sight. Exact to 1e-9 mm and deg."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.config import ConfigError
from vehloc.data.boxes import Box
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.localize import Localizer, PipelineParams, path_heading_deg, travel_start_box
from vehloc.geometry.site_calibration import CameraCalibration

LENGTH_MM, WIDTH_MM = 4800.0, 1850.0


@pytest.mark.parametrize(("heading_deg", "depth_mm"), [(90.0, LENGTH_MM / 2), (-90.0, LENGTH_MM / 2),
                                                       (0.0, WIDTH_MM / 2), (180.0, WIDTH_MM / 2)])
def test_a_car_straight_ahead_starts_half_its_extent_beyond_the_nearest_point(heading_deg: float, depth_mm: float):
    box = travel_start_box(np.array([0.0, 20000.0]), np.array([0.0, -5000.0]), LENGTH_MM, WIDTH_MM, heading_deg)
    np.testing.assert_allclose(box.centre_mm, [0.0, 20000.0 + depth_mm], atol=1e-9)
    assert box.heading_deg == heading_deg and (box.length_mm, box.width_mm) == (LENGTH_MM, WIDTH_MM)


def test_an_oblique_line_of_sight_weighs_length_and_width_by_its_angle():
    nearest, foot = np.array([3000.0, 4000.0]), np.zeros(2)  # sight (0.6, 0.8)
    box = travel_start_box(nearest, foot, LENGTH_MM, WIDTH_MM, 90.0)  # forward (0, 1), left (-1, 0)
    depth_mm = LENGTH_MM / 2 * 0.8 + WIDTH_MM / 2 * 0.6
    np.testing.assert_allclose(box.centre_mm, nearest + depth_mm * np.array([0.6, 0.8]), atol=1e-9)


def test_the_fit_without_key_points_is_off_unless_asked():
    assert PipelineParams.from_config().fit_from_travel is False
    assert PipelineParams.from_config(fit_from_travel=True).fit_from_travel is True


@pytest.mark.parametrize("heading_deg", [90.0, -90.0, 30.0, 180.0])
def test_a_path_points_from_its_first_point_to_its_last(heading_deg: float):
    """Points along a straight path, off it across by +-40 mm in the pattern + - - + (uncorrelated with the
    distance along it): the heading is the path's axis, pointed the way the path went (to 1e-9 deg)."""
    forward = np.array([np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))])
    left = np.array([-forward[1], forward[0]])
    steps = np.arange(12.0)
    across_mm = 40.0 * np.tile([1.0, -1.0, -1.0, 1.0], 3)
    points = np.array([1000.0, 20000.0]) + np.outer(300.0 * steps, forward) + np.outer(across_mm, left)
    heading = path_heading_deg(points, min_extent_mm=1000.0)
    assert heading is not None
    assert abs((heading - heading_deg + 180.0) % 360.0 - 180.0) < 1e-9


def test_a_path_too_short_or_unmapped_gives_no_heading():
    along_y = np.array([[0.0, 0.0], [0.0, 400.0], [0.0, 900.0]])
    assert path_heading_deg(along_y, min_extent_mm=1000.0) is None
    assert path_heading_deg(along_y, min_extent_mm=800.0) == pytest.approx(90.0, abs=1e-9)
    assert path_heading_deg(np.array([[0.0, 0.0], [np.nan, np.inf], [np.nan, 0.0]]), 0.0) is None


def test_the_motion_window_and_the_fit_gate_are_checked():
    assert PipelineParams.from_config().heading_from_motion is True
    with pytest.raises(ConfigError, match="motion_window_frames: must be >= 2, got 1"):
        PipelineParams.from_config(motion_window_frames=1)
    with pytest.raises(ConfigError, match=r"min_fit_iou: must be in \[0, 1\], got 1.5"):
        PipelineParams.from_config(min_fit_iou=1.5)


class _ScriptedExtractor:
    """Stands in for the background model: the boxes of each frame, in order."""

    def __init__(self, boxes_per_frame: list[list[Box]]) -> None:
        self.boxes_per_frame = iter(boxes_per_frame)

    def apply(self, frame_bgr: np.ndarray) -> list[Box]:
        return next(self.boxes_per_frame)


def test_the_path_skips_the_frames_whose_edge_cuts_the_vehicle():
    """A car drives up the image towards the camera; its box's bottom reaches the frame's bottom edge in the last
    frames, where the box bottom stops moving with the car. Only the frames clear of the edge give road points,
    and each is exactly the road point under its box's bottom (to 1e-9 mm)."""
    camera = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)
    calibration = CameraCalibration(camera.road_to_image(), (1280, 720), camera, 0.5, "test camera")
    bottoms_px = [600, 620, 640, 660, 680, 700, 716, 718, 720, 720]
    boxes = [[Box(600, bottom - 200, 760, bottom)] for bottom in bottoms_px]
    localizer = Localizer(classifier=None, calibration=calibration)
    localizer.extractor = _ScriptedExtractor(boxes)
    frame = np.zeros((720, 1280, 3), np.uint8)
    for index in range(len(boxes)):
        localizer.process(index, frame)
    (state,) = localizer.states.values()
    margin_px = localizer.params.border_margin_px
    clear = [i for i, bottom in enumerate(bottoms_px) if bottom < 720 - margin_px]
    assert state.ground_frames == clear
    expected_mm = camera.image_to_road(np.array([[boxes[i][0].centre_px[0], bottoms_px[i] - 1.0] for i in clear]))
    np.testing.assert_allclose(np.array(state.ground_points_mm), expected_mm, atol=1e-9)
