"""Moving vehicles against a rendered scene's truth (`vehloc.benchmark.moving`): the truth read back exactly as the
scene wrote it, and a record's errors exact for a fit moved or turned by known amounts."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from vehloc.benchmark.moving import TruthCar, matched_car, moving_error, read_truth_cars
from vehloc.data.boxes import Box
from vehloc.demo.table2_cases import scene_spec
from vehloc.geometry.pipeline.localize import Estimate, Status, VehicleRecord
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.uncertainty import Uncertainty
from vehloc.synth.scene import write_scene

FOOT_MM = np.array([0.0, -10000.0])
TRUTH = VehicleBox(np.array([1500.0, 20000.0]), -90.0, 4600.0, 1800.0)  # 30 m from the foot, driving towards it
TRUTH_BOX_PX = Box(100, 80, 160, 120)


def one_car(frame: int = 7) -> list[TruthCar]:
    """A car with a footprint and a box in frames 5 to 9, `TRUTH` and `TRUTH_BOX_PX` at `frame`."""
    footprints = tuple(replace(TRUTH, centre_mm=TRUTH.centre_mm + (f - frame) * np.array([0.0, -1000.0]))
                       for f in range(5, 10))
    return [TruthCar(0, 9, footprints, tuple(TRUTH_BOX_PX.shifted(0, f - frame) for f in range(5, 10)), 5)]


def record_with_fit(box: VehicleBox, box_px: Box = TRUTH_BOX_PX, frame: int = 7) -> VehicleRecord:
    fit = Estimate("fit", box, None, Uncertainty.combined((0.0, 0.0), (0.0, 0.0)), 0.8, "travel")
    return VehicleRecord(3, frame, box_px, Status.LOCALIZED, model_id=9, estimates=(fit,))


def test_the_truth_is_read_back_as_the_scene_wrote_it(tmp_path: Path) -> None:
    """A rendered car driving to its stop: at its stop frame the footprint read back has the corners the scene's truth
    gives (to 1e-6 mm, in its order) and the box its box."""
    spec = scene_spec("table2_close_0", ["scene.empty_frames=3", "scene.drive_frames=4", "scene.stopped_frames=2",
                                         "scene.cars.0.approach_mm=3000"])
    _, truth_path = write_scene(spec, tmp_path)
    written = json.loads(truth_path.read_text())["cars"][0]
    (car,) = read_truth_cars(truth_path)
    assert car.model_id == written["model_id"] and car.first_frame == written["per_frame_from"]
    footprint, box = car.at(written["stop_frame"])
    np.testing.assert_allclose(footprint.corners_mm(), written["footprint_corners_mm"], atol=1e-6)
    assert box == Box.from_inclusive(*written["boxes_xyxy_px"][written["stop_frame"] - written["per_frame_from"]])
    assert car.at(car.first_frame - 1) is None and car.at(spec.frame_count) is None


@pytest.mark.parametrize("shift_mm", [800.0, -600.0])
def test_a_fit_moved_along_the_heading_is_off_by_that_much(shift_mm: float) -> None:
    """The fit moved `shift_mm` away from the camera (negative: towards it): the centre's and the near end's errors are
    that distance, the near end's along the heading signed as moved, the heading exact."""
    moved = replace(TRUTH, centre_mm=TRUTH.centre_mm + shift_mm * np.array([0.0, 1.0]))
    error = moving_error(record_with_fit(moved), one_car(), FOOT_MM, 0.5)
    assert error is not None and error.car_index == 0 and error.model_named and error.frame == 7
    assert error.centre_error_mm == pytest.approx(abs(shift_mm))
    assert error.near_end_error_mm == pytest.approx(abs(shift_mm))
    assert error.near_end_along_mm == pytest.approx(shift_mm)
    assert error.heading_error_deg == pytest.approx(0.0)
    assert error.distance_mm == pytest.approx(np.hypot(1500.0, 30000.0))


def test_a_fit_turned_about_its_centre_is_off_in_heading_only_at_the_centre() -> None:
    """Turned 2 deg: the heading's error is 2 deg and the centre's none; the near end's is the arc of half the length."""
    error = moving_error(record_with_fit(replace(TRUTH, heading_deg=-88.0)), one_car(), FOOT_MM, 0.5)
    assert error is not None
    assert error.heading_error_deg == pytest.approx(2.0)
    assert error.centre_error_mm == pytest.approx(0.0, abs=1e-9)
    assert error.near_end_error_mm == pytest.approx(2 * 2300.0 * np.sin(np.radians(1.0)))


def test_a_record_is_matched_to_the_car_its_box_overlaps_most_or_to_none() -> None:
    """Two cars at one frame: the record's box goes to the one it overlaps more; a box overlapping neither by the
    threshold, a record not localized and a frame the car is not in are matched to none."""
    other = TruthCar(1, 4, (TRUTH,), (TRUTH_BOX_PX.shifted(30, 0),), 7)
    cars = one_car() + [other]
    assert matched_car(TRUTH_BOX_PX.shifted(20, 0), cars, 7, 0.3)[0].index == 1
    assert matched_car(TRUTH_BOX_PX.shifted(5, 0), cars, 7, 0.3)[0].index == 0
    assert matched_car(TRUTH_BOX_PX.shifted(200, 0), cars, 7, 0.3) is None
    assert matched_car(TRUTH_BOX_PX, cars, 12, 0.3) is None
    not_localized = replace(record_with_fit(TRUTH), status=Status.NOT_LOCALIZED, estimates=())
    assert moving_error(not_localized, cars, FOOT_MM, 0.3) is None
