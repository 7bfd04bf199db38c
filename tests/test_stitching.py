"""A video's vehicles once their tracks are done: two measured tracks of one vehicle joined (the later one starting where
the earlier one's steady motion puts it, at its speed), others left apart, also where one was measured by its box's
bottom and the other at its centre; a path across the traffic's direction not measured. Exact constant-velocity paths on
the road, so the joined speed is exact."""

from __future__ import annotations

import numpy as np
import pytest

from dataclasses import replace

from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.outcome import ReasonCode
from vehloc.geometry.pipeline.stitching import stitch
from vehloc.geometry.pipeline.track_speed import (ModelSource, SpeedParams, SpeedStatus, TrackSpeeds, VehiclePath,
                                                  VehicleSpeed, along_traffic)
from vehloc.geometry.speed import SpeedFit, fit_speed

FPS = 25.0
PARAMS = SpeedParams.from_config()
CAMERA = PinholeCamera.look_at((-7000.0, -4000.0, 9000.0), (0.0, 24000.0, 0.0), 1100.0, 1280, 720, 0.0)
SPEEDS = TrackSpeeds(TrueModelClassifier(9), CameraCalibration(CAMERA.road_to_image(), (1280, 720), CAMERA, 0.0,
                                                               "test camera"), PARAMS, FPS, 1.0, 1.0)
SPIRIOR_MM = (4840.0, 1850.0, 1465.0)


def _refit(path: VehiclePath) -> SpeedFit:
    fit = fit_speed(path.points_mm, path.frames / FPS, 0.0, 6, 3000.0)
    assert isinstance(fit, SpeedFit)
    return fit


def _vehicle(track_id: int, frames: range, speed_kmh: float, x_mm: float = 1750.0, start_y_mm: float = 60000.0,
             heading_deg: float = -90.0) -> VehicleSpeed:
    """A vehicle measured in `frames`, at `speed_kmh` from (x_mm, start_y_mm) at frame 0 along `heading_deg`."""
    frame_array = np.array(list(frames))
    direction = np.array([np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))])
    points = np.array([x_mm, start_y_mm]) + np.outer(frame_array / FPS * speed_kmh / 3.6 * 1000.0, direction)
    path = VehiclePath(frame_array, points, np.zeros((len(frame_array), 2)), np.zeros((len(frame_array), 4), int))
    return VehicleSpeed(track_id, int(frame_array[0]), int(frame_array[-1]), FPS, path, _refit(path),
                        seen_frames=frame_array, seen_boxes_px=np.zeros((len(frame_array), 4), int))


def test_two_tracks_of_one_vehicle_are_joined_and_measured_together() -> None:
    first, second = _vehicle(1, range(0, 30), 80.0), _vehicle(4, range(45, 80), 80.0)
    beside = _vehicle(2, range(10, 70), 80.0, x_mm=5250.0)  # the next lane at the same speed: 3.5 m off
    faster = _vehicle(3, range(90, 120), 88.0)  # the same lane later, 10 % faster
    vehicles = stitch([first, beside, faster, second], PARAMS.stitch, _refit, SPEEDS.at_centre)
    assert [v.track_id for v in vehicles] == [1, 2, 3]
    joined = vehicles[0]
    assert joined.joined_track_ids == (1, 4) and joined.first_frame == 0 and joined.last_frame == 79
    assert joined.path.frames.tolist() == list(range(30)) + list(range(45, 80))
    assert joined.speed.speed_kmh == pytest.approx(80.0, abs=1e-9) and joined.speed.points == 65
    assert joined.row()["joined_track_ids"] == "1 4" and vehicles[1].joined_track_ids == ()


def _unchanged(vehicle: VehicleSpeed, length_mm: float) -> VehicleSpeed:
    return vehicle


@pytest.mark.parametrize("heading_deg", [-90.0, 90.0])
@pytest.mark.parametrize("box_bottom_first", [False, True])
def test_a_track_measured_by_its_box_bottom_is_joined_at_its_centre(heading_deg: float, box_bottom_first: bool) -> None:
    """One Spirior, one track measured at its centre (its model's shape), the other by its box's bottom (no likely
    model's size there: its nearest end's ground line, half its length, 2.42 m, nearer the camera than its centre):
    apart without moving it (2.42 m is beyond the 1 m offset), joined with it, as a Spirior measured on its centre's
    points only (the box's bottom is no fixed point of a vehicle), and followed in every frame of both."""
    start_y = 80000.0 if heading_deg < 0 else 20000.0  # towards the camera (its front nearest) or away (its rear)
    first_frames, later_frames = (range(0, 30), range(45, 80))
    bottom_frames, centre_frames = (first_frames, later_frames) if box_bottom_first else (later_frames, first_frames)
    centre = replace(_vehicle(4 if box_bottom_first else 1, centre_frames, 80.0, start_y_mm=start_y,
                              heading_deg=heading_deg), dims_mm=SPIRIOR_MM, model="Spirior", model_id=9)
    bottom = _vehicle(1 if box_bottom_first else 4, bottom_frames, 80.0, start_y_mm=start_y,
                      heading_deg=heading_deg)
    # its end nearer the camera (at Y -4 m): its front or its rear
    nearest_end = bottom.path.points_mm - [0.0, SPIRIOR_MM[0] / 2.0]
    bottom_path = replace(bottom.path, points_mm=nearest_end)
    bottom = replace(bottom, path=bottom_path, speed=_refit(bottom_path), reference="box_bottom",
                     model_source=ModelSource.UNKNOWN)
    vehicles = sorted([centre, bottom], key=lambda v: v.track_id)
    assert [v.joined_track_ids for v in stitch(vehicles, PARAMS.stitch, _refit, _unchanged)] == [(), ()]
    joined = stitch(vehicles, PARAMS.stitch, _refit, SPEEDS.at_centre)
    assert len(joined) == 1 and joined[0].joined_track_ids == (1, 4)
    assert joined[0].reference == "shape_top" and joined[0].model == "Spirior"
    assert joined[0].speed.speed_kmh == pytest.approx(80.0, abs=1e-9) and joined[0].speed.points == len(centre_frames)
    assert joined[0].path.frames.tolist() == list(centre_frames)
    assert joined[0].seen_frames.tolist() == list(first_frames) + list(later_frames)


def test_tracks_too_far_apart_in_time_or_on_the_road_are_not_joined() -> None:
    late = [_vehicle(1, range(0, 30), 80.0), _vehicle(2, range(30 + int(2.5 * FPS), 100), 80.0)]  # 2.5 s later
    off = [_vehicle(1, range(0, 30), 80.0), _vehicle(2, range(45, 80), 80.0, start_y_mm=58500.0)]  # 1.5 m behind
    for vehicles in (late, off):
        assert [v.joined_track_ids for v in stitch(vehicles, PARAMS.stitch, _refit, SPEEDS.at_centre)] == [(), ()]


def test_a_path_across_the_traffic_is_not_measured() -> None:
    """Two-way traffic along the road, and one track 10.7 deg off it (boxes of two vehicles in two lanes)."""
    vehicles = [_vehicle(i, range(0, 40), 80.0, heading_deg=-90.0 if i % 2 else 90.0) for i in range(1, 7)]
    vehicles.append(_vehicle(7, range(0, 20), 160.0, heading_deg=-100.7))
    checked = along_traffic(vehicles, PARAMS)
    assert [v.status for v in checked[:6]] == [SpeedStatus.MEASURED] * 6
    assert checked[6].speed.code is ReasonCode.PATH_ACROSS_TRAFFIC and "10.7 deg" in checked[6].speed.message
