"""The three key-footprint-point detectors together on one ROI, as the combination step uses them: a plate pose
gives a plate and no wheels, a side-on pose wheels and no plate, and the footprint lines serve both."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from detector_scenes import (
    BLACK, SILVER, SMALL_PLATE_QUARTER_POSES, heading_error_deg, render_case,
)
from vehloc.data.boxes import Box
from vehloc.geometry import keypoints
from vehloc.geometry.footprint import FootprintParams, detect_footprint
from vehloc.geometry.keypoints import DetectorParams, paper_placement
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.plate import PlateParams, detect_plate
from vehloc.geometry.roi import Silhouette
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.wheels import WheelParams, detect_wheels
from vehloc.synth.body import catalog_shapes
from vehloc.synth.catalog import vehicle_specs


def detect_all(case):
    road_to_image = case.camera.road_to_image()
    lines = detect_footprint(case.roi_bgr, case.mask, case.offset_px, road_to_image, case.camera_foot_mm,
                             FootprintParams.from_config())
    plate = detect_plate(case.roi_bgr, case.mask, case.offset_px, PlateParams.from_config())
    wheels = detect_wheels(case.roi_bgr, case.mask, case.offset_px, road_to_image, case.camera_foot_mm,
                           WheelParams.from_config())
    return lines, plate, wheels


@pytest.mark.parametrize("car", [SILVER, BLACK])
def test_plate_branch(car):
    """Rear towards the camera at 4 m: a plate (P within 2 px), no wheels, the length axis within 1.5 deg."""
    case = render_case(car, "near_rear")
    lines, plate, wheels = detect_all(case)
    assert plate is not None and wheels is None
    assert np.linalg.norm(plate.centre_px - case.camera.project(case.facing_plate().centre_mm[None])[0]) <= 2.0
    assert heading_error_deg(lines.length_heading_deg, case.pose.heading_deg) <= 1.5


@pytest.mark.parametrize("car", [SILVER, BLACK])
def test_wheel_branch(car):
    """Side-on at 10 m (Table 2 "middle 0"): two wheels whose outer contacts lie within 1.5 px of l_S, no plate,
    and Q between the two contacts."""
    case = render_case(car, "table2_middle_0")
    lines, plate, wheels = detect_all(case)
    assert plate is None and wheels is not None and len(wheels.wheels) == 2
    for wheel in wheels.wheels:
        assert abs(lines.side_line_px @ np.append(wheel.outer_contact_px, 1.0)) <= 1.5
    rear, front = (wheel.contact_px for wheel in wheels.wheels)
    along = (wheels.q_px - rear) @ (front - rear) / np.sum((front - rear) ** 2)
    assert 0.4 < along < 0.6


def placement_of(case, car: tuple[int, int], params: DetectorParams, visible_end: str):
    """The paper's placement of the case's car (its true model) with exact calibration and mask."""
    calibration = CameraCalibration(case.camera.road_to_image(), (case.camera.width_px, case.camera.height_px),
                                    case.camera, 0.5, "test camera")
    height_px, width_px = case.mask.shape
    roi = Box(int(case.offset_px[0]), int(case.offset_px[1]), int(case.offset_px[0]) + width_px,
              int(case.offset_px[1]) + height_px)
    silhouette = Silhouette(case.mask, case.mask.astype(np.float32), np.zeros_like(case.mask), case.mask,
                            np.ones(case.mask.shape, np.float32), 0)
    spec = next(spec for spec in vehicle_specs() if spec.model_id == car[0])
    return paper_placement(case.roi_bgr, silhouette, roi, calibration, spec, catalog_shapes()[car[0]], params,
                           visible_end)


def test_a_plate_is_taken_only_with_a_plates_width_on_the_road():
    """The plate branch of the paper's placement on the rear view: the 440-mm plate is taken; told that plates
    are 10-20 mm wide, the placement does not take it, falls to the wheel branch (no wheels in this view) and
    says what the part would measure: a range that holds the plate's true 440 mm."""
    case = render_case(SILVER, "near_rear")
    params = DetectorParams.from_config()
    assert placement_of(case, SILVER, params, "rear").kind == "plate"
    narrow = dataclasses.replace(params, plate=dataclasses.replace(params.plate, width_range_mm=(10.0, 20.0)))
    refused = placement_of(case, SILVER, narrow, "rear")
    assert isinstance(refused, NotPlaced) and refused.code == ReasonCode.NO_KEY_POINTS
    low_mm, high_mm = (float(v) for v in re.search(r"found no wheel; a plate-like part would be (\d+)-(\d+) mm wide",
                                                   refused.message).groups())
    assert low_mm < 440.0 < high_mm


@pytest.mark.parametrize(("car", "pose"), [(SILVER, "near_rear"), (SILVER, "far_rear_20"), (BLACK, "near_rear")])
@pytest.mark.parametrize("lamps_off_deg", [0.0, 6.0, -6.0])
def test_the_rear_lamps_heading_is_weighed_against_the_bodys_lines(monkeypatch, car, pose, lamps_off_deg):
    """Rear views 4 and 10 m away, their lamps' heading told as the truth turned by `lamps_off_deg`: the plate
    branch's box lies within 0.5 deg of the truth either way (measured: 0.08 deg at most), the box along the body's
    lines chosen by the silhouette where the lamps are off, not the lamps' taken alone. Not every view allows it: the
    black car 10 m away, its lamps told 6 deg off one way, keeps the lamps' box (6 deg off, measured), whose shape
    covers its silhouette better."""
    case = render_case(car, pose)
    monkeypatch.setattr(keypoints, "rear_lamps_heading_deg",
                        lambda *args: (case.pose.heading_deg + lamps_off_deg) % 180.0)
    placement = placement_of(case, car, DetectorParams.from_config(), "rear")
    assert placement.kind == "plate"
    assert heading_error_deg(placement.box.heading_deg, case.pose.heading_deg) <= 0.5


@pytest.mark.parametrize("pose", list(SMALL_PLATE_QUARTER_POSES) + ["small_rear_24"])
def test_a_small_plate_gives_way_to_two_wheels(pose):
    """A small plate (15-18 px, its sides its colour's outline) is found in each view (P within 1 px); where two
    wheels are found too (a rear quarter 15-17 m away) the placement takes the wheels, where none are (the rear
    end-on, 22 m away) the plate."""
    case = render_case(SILVER, pose)
    _, plate, wheels = detect_all(case)
    assert plate is not None and plate.small
    assert np.linalg.norm(plate.centre_px - case.camera.project(case.facing_plate().centre_mm[None])[0]) <= 1.0
    placement = placement_of(case, SILVER, DetectorParams.from_config(), "rear")
    expected = "wheels" if pose in SMALL_PLATE_QUARTER_POSES else "plate"
    assert (wheels is not None and len(wheels.wheels) == 2) == (expected == "wheels")
    assert placement.kind == expected
