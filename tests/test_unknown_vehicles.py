"""A vehicle of no likely model's size (a truck the classifier does not know): measured by the road point under its
box's bottom, at its true speed, with no model; a box that held another measured vehicle (their merged blob) or a
fragment's uncertain speed not measured. Exact boxes along exact paths, rounded to whole pixels."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.data.boxes import Box
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.outcome import ReasonCode
from vehloc.geometry.pipeline.track_speed import (ModelSource, SpeedParams, SpeedStatus, TrackSpeeds, VehicleSpeed,
                                                  assign_lanes)
from vehloc.geometry.pipeline.tracker import VehicleTrack
from vehloc.geometry.pipeline.unknown_vehicles import apart_from_known
from vehloc.geometry.pipeline.votes import TrackVotes
from vehloc.geometry.speed import SpeedFit

FPS = 25.0
CAMERA = PinholeCamera.look_at((-7000.0, -4000.0, 9000.0), (0.0, 24000.0, 0.0), 1100.0, 1280, 720, 0.0)
SPIRIOR = 9
PARAMS = SpeedParams.from_config(edge_inset_px=0.0)
SPEEDS = TrackSpeeds(TrueModelClassifier(SPIRIOR),
                     CameraCalibration(CAMERA.road_to_image(), (1280, 720), CAMERA, 0.0, "test camera"), PARAMS, FPS,
                     1.0, 1.0)
TRUCK_HALF_WIDTH_PX, TRUCK_HEIGHT_PX = 90, 260
"""A box far wider and taller than a Spirior's anywhere on this road (its own are 40-110 px wide, 30-90 px tall)."""


def _truck_track(track_id: int, lateral_mm: float, speed_kmh: float, start_y_mm: float = 60000.0,
                 frames: int = 60) -> VehicleTrack:
    """A truck driving towards the camera at `speed_kmh`: the middle of its front's ground line at (lateral_mm,
    start_y_mm - travel), its box that point's pixel at the middle of its bottom row."""
    track = VehicleTrack(track_id, TrackVotes(4))
    for frame in range(frames):
        front_mm = np.array([[lateral_mm, start_y_mm - frame / FPS * speed_kmh / 3.6 * 1000.0]])
        u, v = CAMERA.road_to_image()(front_mm)[0]
        box = Box(int(round(u)) - TRUCK_HALF_WIDTH_PX, int(round(v)) - TRUCK_HEIGHT_PX,
                  int(round(u)) + TRUCK_HALF_WIDTH_PX,
                  int(round(v)) + 1)
        track.frames.append(frame)
        track.boxes.append(box)
        track.add_ground_point(CAMERA.image_to_road(np.array([[box.centre_px[0], box.y1 - 1.0]]))[0], frame)
    track.votes.add(np.zeros((720, 1280, 3), np.uint8), track.boxes[-1])
    return track


def test_a_vehicle_of_no_likely_models_size_is_measured_by_its_box_bottom() -> None:
    truck = SPEEDS.measure(_truck_track(1, 1750.0, 72.0))
    assert [c.speed.code for c in truck.candidates] == [ReasonCode.BOX_NOT_MODEL_SIZE]  # the vote's Spirior refused
    assert truck.status == SpeedStatus.MEASURED and truck.model_source == ModelSource.UNKNOWN
    # tolerance: the box's bottom row rounded to whole pixels, 0.5 px of 12-60 mm/px over 42 m of road
    assert truck.speed.speed_kmh == pytest.approx(72.0, rel=0.005)
    row = truck.row()
    assert row["reference"] == "box_bottom" and row["model"] == "" and row["length_mm"] is None
    assert row["voted_model_id"] == SPIRIOR and row["model_source"] == "none: no likely model's size"


def test_without_the_setting_it_is_not_measured() -> None:
    speeds = TrackSpeeds(SPEEDS.classifier, SPEEDS.calibration, replace(PARAMS, unknown_by_box_bottom=False), FPS,
                         1.0, 1.0)
    truck = speeds.measure(_truck_track(1, 1750.0, 72.0))
    assert truck.speed.code is ReasonCode.BOX_NOT_MODEL_SIZE and truck.model_source == ModelSource.VOTE


def _known(track_id: int, lateral_mm: float, speed_kmh: float, start_y_mm: float = 60000.0) -> VehicleSpeed:
    """A measured vehicle of a known model whose steady motion is the truck track's front point's."""
    truck = SPEEDS.measure(_truck_track(track_id, lateral_mm, speed_kmh, start_y_mm))
    return replace(truck, model_source=ModelSource.VOTE, reference="shape_top")


def test_a_box_that_held_a_measured_vehicle_is_their_merged_blob() -> None:
    truck = SPEEDS.measure(_truck_track(1, 1750.0, 72.0))
    beside = _known(2, 3250.0, 72.0, 62000.0)  # 1.5 m to the side, 2 m behind: in the truck's box all along
    far = _known(3, 5250.0 + 3500.0, 72.0)  # two lanes over: never in it
    kept = apart_from_known([truck, far], PARAMS, CAMERA.road_to_image())
    assert kept[0].status == SpeedStatus.MEASURED
    merged = apart_from_known([truck, beside, far], PARAMS, CAMERA.road_to_image())
    assert merged[0].speed.code is ReasonCode.BOX_NOT_MODEL_SIZE and "100% of its frames" in merged[0].speed.message
    assert [v.status for v in merged[1:]] == [SpeedStatus.MEASURED] * 2


def test_only_a_vehicle_beside_it_on_the_road_makes_a_merged_blob() -> None:
    """A car 30 m behind the truck in the next lane is inside the truck's tall box in the image, not beside it on the
    road: the truck is measured. A car beside it whose track begins 10 frames into the truck's and outlasts it: their
    merged blob (50 of 60 frames)."""
    truck = SPEEDS.measure(_truck_track(1, 1750.0, 72.0))
    far_behind = _known(2, 3250.0, 72.0, 90000.0)
    checked = apart_from_known([truck, far_behind], PARAMS, CAMERA.road_to_image())[0]
    assert checked.status == SpeedStatus.MEASURED
    later = replace(_known(3, 3250.0, 72.0, 62000.0), first_frame=10, last_frame=90)
    merged = apart_from_known([truck, later], PARAMS, CAMERA.road_to_image())[0]
    assert merged.speed.code is ReasonCode.BOX_NOT_MODEL_SIZE


def test_a_fragments_uncertain_speed_is_not_measured() -> None:
    truck = SPEEDS.measure(_truck_track(1, 1750.0, 72.0))
    sigma_kmh = 0.3 * truck.speed.speed_kmh
    uncertain = replace(truck, speed=replace(truck.speed, sigma_kmh=sigma_kmh))
    checked = apart_from_known([uncertain], PARAMS, CAMERA.road_to_image())[0]
    assert checked.speed.code is ReasonCode.BOX_NOT_MODEL_SIZE and "30% uncertain" in checked.speed.message


def test_a_vehicle_measured_by_its_box_bottom_takes_a_lane_and_makes_none() -> None:
    """Known vehicles in lanes at 1.75 m and 5.25 m; trucks' box bottoms at 3.0 m and 4.5 m across (their boxes'
    middles, not their centres), had they been clustered with them, would have made the two lanes one."""
    vehicles = [_known(1, 1750.0, 72.0), _known(2, 5250.0, 72.0), SPEEDS.measure(_truck_track(3, 3000.0, 72.0)),
                SPEEDS.measure(_truck_track(4, 4500.0, 72.0))]
    lanes = [v.lane for v in assign_lanes(vehicles, replace(PARAMS, lane_gap_mm=1500.0))]
    assert lanes == [0, 1, 0, 1]
    assert isinstance(vehicles[2].speed, SpeedFit)
