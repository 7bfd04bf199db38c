"""The heading of a moving vehicle from its path (`pipeline.heading_from_motion`) and its 1-sigma, and the model
fit's start without key points (`pipeline.fit_from_travel`): the footprint's nearest point is the road point
under the box's bottom, the centre lies half the footprint's extent beyond it along the line of sight. Exact to
1e-9 mm and deg unless a test says otherwise."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from bad_input import write_handmade_onnx

from vehloc.config import ConfigError
from vehloc.data.boxes import Box
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.outcome import ReasonCode
from vehloc.geometry.pipeline.localize import Localizer, Status, travel_start_box, VehicleRecord
from vehloc.geometry.pipeline.settings import LocalizeSettings, PipelineParams
from vehloc.geometry.motion import path_heading, recent_path
from vehloc.geometry.roi import Silhouette
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.infer.classifier import VehicleClassifier

LENGTH_MM, WIDTH_MM = 4800.0, 1850.0
CAMERA = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)
ROAD_TO_IMAGE = CAMERA.road_to_image()


def path_heading_deg(points_mm: np.ndarray, min_extent_mm: float) -> float | None:
    heading = path_heading(points_mm, np.arange(len(points_mm)), min_extent_mm, ROAD_TO_IMAGE, jitter_px=1.0)
    return None if heading is None else heading.heading_deg


def seen_with_jitter(points_mm: np.ndarray, jitter_px: float, rng: np.random.Generator) -> np.ndarray:
    """The road points under box bottoms seen `jitter_px` (1-sigma, in x and in y) off their true image."""
    image_px = ROAD_TO_IMAGE(points_mm)
    return ROAD_TO_IMAGE.inverse(image_px + rng.normal(0.0, jitter_px, image_px.shape))


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
def test_a_path_points_the_way_it_was_travelled(heading_deg: float):
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


def test_the_way_is_the_speeds_not_the_first_and_last_points():
    """Four points a metre apart along +Y and a fifth that jumped back behind the first: the first and last points
    say -Y, the constant-speed motion through all five says +Y (to 1e-9 deg)."""
    points = np.column_stack([np.zeros(5), 20000.0 + np.array([0.0, 1000.0, 2000.0, 3000.0, -100.0])])
    assert path_heading_deg(points, min_extent_mm=1000.0) == pytest.approx(90.0, abs=1e-9)


def test_the_speed_in_sigmas_tells_a_standing_car_from_a_moving_one():
    """Cars 20 m ahead seen for 10 frames with 2 px of jitter, 1,000 of each: for a standing car the speed along its
    path is |N(0, 1)| in its own sigmas (median within 15 % of 0.674, fewer than 2 % at 3 or more), for one moving
    a metre a frame always past 3."""
    rng = np.random.default_rng(2)
    for speed_mm, expected in ((0.0, "standing"), (1000.0, "moving")):
        truth = np.column_stack([np.zeros(10), 20000.0 + speed_mm * np.arange(10)])
        sigmas = np.array([path_heading(seen_with_jitter(truth, 2.0, rng), np.arange(10), 0.0, ROAD_TO_IMAGE,
                                        1.0).speed_sigmas for _ in range(1000)])
        if expected == "standing":
            assert np.median(sigmas) == pytest.approx(0.674, rel=0.15) and np.mean(sigmas >= 3.0) < 0.02
        else:
            assert sigmas.min() > 3.0


def test_a_path_too_short_or_unmapped_gives_no_heading():
    along_y = np.array([[0.0, 0.0], [0.0, 400.0], [0.0, 900.0]])
    assert path_heading_deg(along_y, min_extent_mm=1000.0) is None
    assert path_heading_deg(along_y, min_extent_mm=800.0) == pytest.approx(90.0, abs=1e-9)
    assert path_heading_deg(np.array([[0.0, 0.0], [np.nan, np.inf], [np.nan, 0.0]]), 0.0) is None


def test_the_heading_sigma_is_the_spread_of_headings_from_noisy_paths():
    """Cars 40 m ahead driving along the road at a metre a frame, their box bottoms seen with Gaussian jitter in
    the image: the sigma of a single path (from its residuals about a constant-speed motion, at least 1 px)
    matches the spread of the headings of 1,000 such paths within 15 % (jitter of 3 px, above the floor) or stays
    the 1-px floor (jitter of 0.01 px; two points, which have no residual)."""
    rng = np.random.default_rng(0)
    for count, jitter_px, expected in ((30, 3.0, "residuals"), (6, 3.0, "residuals"), (2, 0.01, "floor")):
        truth = np.column_stack([np.zeros(count), 40000.0 + 1000.0 * np.arange(count)])
        paths = [path_heading(seen_with_jitter(truth, jitter_px, rng), np.arange(count), 500.0, ROAD_TO_IMAGE, 1.0)
                 for _ in range(1000)]
        headings, sigmas = [p.heading_deg for p in paths], [p.sigma_deg for p in paths]
        if expected == "residuals":
            assert np.median(sigmas) == pytest.approx(np.std(headings), rel=0.15)
            assert np.median([p.jitter_px for p in paths]) == pytest.approx(jitter_px, rel=0.15)
        else:
            floor = path_heading(truth, np.arange(count), 500.0, ROAD_TO_IMAGE, 1.0)
            assert floor.sigma_deg > 5 * np.std(headings) and np.allclose(sigmas, floor.sigma_deg, rtol=0.02)


def test_a_box_bottom_that_jumps_along_the_path_makes_its_heading_uncertain():
    """Three road points exactly on one line 40 m ahead, seen at frames 0, 2 and 3 and spanning 2.9 m: at constant
    speed (0, 1.93 and 2.9 m) their heading has the 1-px floor's sigma, inside the 2-deg gate; when the box's
    bottom jumps 2.5 m in the last frame (0, 0.4 and 2.9 m: the blob lost its lower part) the same line is far
    less certain, past the gate. Both point along the road (to 1e-9 deg)."""
    frames = np.array([0.0, 2.0, 3.0])
    steady, jumping = (path_heading(np.column_stack([np.zeros(3), 40000.0 + np.array(along_mm)]), frames, 500.0,
                                    ROAD_TO_IMAGE, 1.0) for along_mm in ([0.0, 2900.0 * 2 / 3, 2900.0], [0.0, 400.0, 2900.0]))
    assert steady.jitter_px == 1.0 and jumping.jitter_px > 2.5
    assert steady.heading_deg == pytest.approx(90.0, abs=1e-9) and jumping.heading_deg == pytest.approx(90.0, abs=1e-9)
    assert jumping.sigma_deg > PipelineParams.from_config().max_motion_sigma_deg > steady.sigma_deg


def test_a_pixel_of_jitter_turns_a_far_path_more_than_a_near_one():
    """The floor of 1 px: across a path along the road, a pixel spans the road's width per pixel there (read
    from the camera's Jacobian, to 1e-6); a far path is the more uncertain one."""
    near = path_heading(np.array([[0.0, 9000.0], [0.0, 11000.0]]), [0, 1], 500.0, ROAD_TO_IMAGE, jitter_px=1.0)
    far = path_heading(np.array([[0.0, 39000.0], [0.0, 41000.0]]), [0, 1], 500.0, ROAD_TO_IMAGE, jitter_px=1.0)
    for path, y_mm in ((near, 10000.0), (far, 40000.0)):
        jacobian = ROAD_TO_IMAGE.inverse.jacobian(ROAD_TO_IMAGE(np.array([[0.0, y_mm - 1000.0], [0.0, y_mm + 1000.0]])))
        across_mm2 = np.mean(jacobian[:, 0, 0] ** 2 + jacobian[:, 0, 1] ** 2)
        assert path.sigma_deg == pytest.approx(np.degrees(np.sqrt(across_mm2 / 2e6)), rel=1e-6)
    assert far.sigma_deg > 2 * near.sigma_deg


def test_the_path_starts_after_its_last_long_gap():
    points = [np.array([0.0, float(f)]) for f in range(10)]
    frames = [0, 1, 2, 9, 10, 11, 13, 14, 20, 21]
    for frame_index, window_frames, max_gap_frames, expected in ((21, 30, 5, [8, 9]), (14, 30, 7, range(8)),
                                                                 (14, 5, 5, [4, 5, 6, 7])):
        path_mm, path_frames = recent_path(points, frames, frame_index, window_frames, max_gap_frames)
        np.testing.assert_array_equal(path_mm[:, 1], list(expected))
        np.testing.assert_array_equal(path_frames, [frames[i] for i in expected])


def test_the_motion_window_and_the_fit_gate_are_checked():
    assert PipelineParams.from_config().heading_from_motion is True
    with pytest.raises(ConfigError, match="motion_window_frames: must be >= 2, got 1"):
        PipelineParams.from_config(motion_window_frames=1)
    with pytest.raises(ConfigError, match="motion_max_gap_frames: must be >= 1, got 0"):
        PipelineParams.from_config(motion_max_gap_frames=0)
    with pytest.raises(ConfigError, match="max_motion_sigma_deg: must be >= 0"):
        PipelineParams.from_config(max_motion_sigma_deg=-1.0)
    with pytest.raises(ConfigError, match="min_speed_sigmas: must be >= 0"):
        PipelineParams.from_config(min_speed_sigmas=-1.0)
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
    (state,) = localizer.tracker.tracks
    margin_px = localizer.params.border_margin_px
    clear = [i for i, bottom in enumerate(bottoms_px) if bottom < 720 - margin_px]
    assert state.ground_frames == clear
    expected_mm = camera.image_to_road(np.array([[boxes[i][0].centre_px[0], bottoms_px[i] - 1.0] for i in clear]))
    np.testing.assert_allclose(np.array(state.ground_points_mm), expected_mm, atol=1e-9)


class _EmptyForeground(_ScriptedExtractor):
    """Scripted boxes, and no vehicle pixels in any ROI: the key-point detectors find nothing."""

    def foreground(self, roi: Box, body: Box | None = None) -> Silhouette:
        empty = np.zeros((roi.height_px, roi.width_px), bool)
        return Silhouette(empty, empty.astype(np.float32), empty, empty, np.ones(empty.shape, np.float32), 0)


def records_of_a_far_car(bottoms_px: np.ndarray, params: PipelineParams,
                         tmp_path: Path) -> tuple[list[VehicleRecord], Localizer]:
    """The records of a car 40 px wide and 24 px high at image column 640 whose box's bottom is at `bottoms_px` in
    successive frames, localized with a handmade ONNX classifier and an empty foreground (no key points)."""
    calibration = CameraCalibration(ROAD_TO_IMAGE, (1280, 720), CAMERA, 0.5, "test camera")
    boxes = [[Box(620, int(round(b)) - 24, 660, int(round(b)))] for b in bottoms_px]
    localizer = Localizer(VehicleClassifier.from_onnx(write_handmade_onnx(tmp_path / "model.onnx")), calibration,
                          dataclasses.replace(LocalizeSettings.compose(), pipeline=params))
    localizer.extractor = _EmptyForeground(boxes)
    frame = np.zeros((720, 1280, 3), np.uint8)
    return [record for index in range(len(boxes)) for record in localizer.process(index, frame)], localizer


@pytest.mark.parametrize(("max_sigma_deg", "unclear"), [(2.0, True), (90.0, False)])
def test_a_moving_vehicle_whose_path_does_not_tell_its_heading_is_not_localized(
        max_sigma_deg: float, unclear: bool, tmp_path: Path):
    """A far car seen in two frames, 1.2 m apart along the road: the pixel's jitter alone makes its path's heading
    uncertain by more than 2 deg, so without key points it is not localized, and says why; with the gate at
    90 deg the path would be used (the record then fails only for want of key points: no footprint lines)."""
    bottoms_px = ROAD_TO_IMAGE(np.array([[0.0, 40000.0], [0.0, 38800.0]]))[:, 1]
    records, localizer = records_of_a_far_car(
        bottoms_px, PipelineParams.from_config(every_frame=True, max_motion_sigma_deg=max_sigma_deg), tmp_path)
    assert [r.status for r in records] == [Status.NOT_LOCALIZED, Status.NOT_LOCALIZED]
    path = localizer.travel(localizer.tracker.tracks[0], 1).recent
    assert path.sigma_deg > 2.0 and path.points == 2
    assert (records[1].reason_code == ReasonCode.PATH_HEADING_UNCERTAIN) is unclear


@pytest.mark.parametrize(("min_speed_sigmas", "unclear"), [(3.0, True), (0.0, False)])
def test_a_moving_vehicle_whose_path_does_not_tell_which_way_is_not_localized(
        min_speed_sigmas: float, unclear: bool, tmp_path: Path):
    """A far car (40 m) whose box's bottom wanders 5 px back and forth over six frames (1.5 m along the road): its
    path has an axis but no clear way along it (speed about 1 sigma from zero), so without key points it is not
    localized and says why; with no minimum speed the path would be used (the heading gate is opened to 90 deg for
    both, and the record then fails only for want of key points)."""
    bottoms_px = np.round(ROAD_TO_IMAGE(np.array([[0.0, 40000.0]]))[0, 1]) + np.array([0, 5, 0, 5, 1, 5])
    params = PipelineParams.from_config(every_frame=True, max_motion_sigma_deg=90.0, min_speed_sigmas=min_speed_sigmas)
    records, localizer = records_of_a_far_car(bottoms_px, params, tmp_path)
    assert all(r.status == Status.NOT_LOCALIZED for r in records)
    path = localizer.travel(localizer.tracker.tracks[0], 5).recent
    assert path.speed_sigmas < 3.0 and path.sigma_deg < 90.0
    assert records[-1].reason_code == (ReasonCode.PATH_WAY_UNCLEAR if unclear else ReasonCode.NO_FOOTPRINT_LINES)
