"""A track's travel by one rule (`vehloc.geometry.pipeline.travel`): its whole road path's heading, pointed the way
it went; the end it shows the camera from that way; a moving vehicle's recent heading or the code of why its path
cannot give it. Exact paths, headings to 1e-9 deg."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.outcome import ReasonCode
from vehloc.geometry.pipeline.settings import PipelineParams
from vehloc.geometry.pipeline.tracker import VehicleTrack
from vehloc.geometry.pipeline.travel import track_travel
from vehloc.geometry.pipeline.votes import TrackVotes

CAMERA = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)
FOOT_MM = CAMERA.centre_mm[:2]
PARAMS = PipelineParams.from_config()


def track_along(start_mm: tuple[float, float], step_mm: tuple[float, float], frames: int,
                stopped_frames: int = 0) -> VehicleTrack:
    """A track whose road points go from `start_mm` by `step_mm` a frame, then stand for `stopped_frames`."""
    track = VehicleTrack(1, TrackVotes(4))
    for i in range(frames + stopped_frames):
        point = np.asarray(start_mm) + min(i, frames - 1) * np.asarray(step_mm)
        track.add_ground_point(point, i)
    return track


@pytest.mark.parametrize(("step_mm", "heading_deg", "end"), [
    ((0.0, 200.0), 90.0, "rear"),      # along the road, away from the camera: its rear is seen
    ((0.0, -200.0), -90.0, "front"),   # towards the camera: its front
    ((200.0, 0.0), 0.0, None),         # across the road, left to right: the heading alone
])
def test_a_stopped_vehicle_came_the_way_its_path_went(step_mm: tuple[float, float], heading_deg: float,
                                                      end: str | None) -> None:
    start = (-3000.0, 20000.0) if step_mm[0] else (0.0, 20000.0)
    went = track_travel(track_along(start, step_mm, 40, stopped_frames=25), 64, False, PARAMS, CAMERA.road_to_image(),
                  FOOT_MM)
    assert went.moving is False and went.motion is None and went.unclear is None
    assert abs((went.came_heading_deg - heading_deg + 180.0) % 360.0 - 180.0) < 1e-9
    if end is not None:
        assert went.visible_end == end


def test_a_path_shorter_than_the_minimum_tells_nothing() -> None:
    went = track_travel(track_along((0.0, 20000.0), (0.0, 20.0), 40), 39, True, PARAMS, CAMERA.road_to_image(), FOOT_MM)
    assert went.came_heading_deg is None and went.visible_end is None
    assert went.unclear.code == ReasonCode.PATH_TOO_SHORT and went.motion is None


def test_a_moving_vehicle_points_where_its_recent_path_goes() -> None:
    went = track_travel(track_along((0.0, 15000.0), (0.0, 300.0), 40), 39, True, PARAMS, CAMERA.road_to_image(), FOOT_MM)
    assert went.unclear is None and abs(went.motion.heading_deg - 90.0) < 1e-9
    assert went.motion.points == PARAMS.motion_window_frames
