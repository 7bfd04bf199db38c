"""A vehicle's model checked against its boxes' height: exact boxes of the catalog's shapes along exact paths, with a
cast shadow under each, against the true models and speeds."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.config import ConfigError
from vehloc.data.boxes import Box
from vehloc.geometry.box_reference import box_height_excess, shape_pixels
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.pipeline.model_choice import box_height_reference, choose_models
from vehloc.geometry.pipeline.track_speed import ModelSource, SpeedParams, TrackSpeeds, VehicleSpeed
from vehloc.geometry.speed import SpeedFit

FPS = 25.0
CAMERA = PinholeCamera.look_at((-7000.0, -4000.0, 9000.0), (0.0, 24000.0, 0.0), 1100.0, 1280, 720, 0.0)
SPIRIOR, MERCEDES_R = 9, 2  # 1465 mm and 1663 mm high
SHADOW = 0.12
"""The cast shadow under every vehicle: its box this fraction of the shape's height taller at the bottom."""
CLASSIFIER = TrueModelClassifier(SPIRIOR)
SPEEDS = TrackSpeeds(CLASSIFIER, CameraCalibration(CAMERA.road_to_image(), (1280, 720), CAMERA, 0.0, "test camera"),
                     SpeedParams.from_config(edge_inset_px=0.0), FPS, 1.0, 1.0)


def _box(model_id: int, centre_mm: np.ndarray) -> Box:
    """The box of the pixels the model's shape covers at least half, its bottom lowered by the shadow."""
    pixels = shape_pixels(CAMERA, CLASSIFIER.metadata.shape_of(model_id), centre_mm, -90.0)
    height_px = np.ptp(pixels[:, 1])
    return Box(int(np.ceil(pixels[:, 0].min())), int(np.ceil(pixels[:, 1].min())),
               int(np.floor(pixels[:, 0].max())) + 1, int(np.floor(pixels[:, 1].max() + SHADOW * height_px)) + 1)


def _vehicle(track_id: int, true_model: int, lateral_mm: float, speed_kmh: float,
             vote: dict[int, float]) -> VehicleSpeed:
    """A vehicle of `true_model` driving towards the camera at `speed_kmh`, each model of `vote` measured with its
    probability (the first the vote's first)."""
    frames = np.arange(40)
    centres = np.column_stack([np.full(40, lateral_mm), 60000.0 - frames / FPS * speed_kmh / 3.6 * 1000.0])
    boxes = {int(f): _box(true_model, c) for f, c in zip(frames, centres)}
    bottoms = CAMERA.image_to_road(np.array([[b.centre_px[0], b.y1 - 1.0] for b in boxes.values()]))
    candidates = tuple(SPEEDS.candidate(model_id, probability, frames, bottoms, boxes, -90.0,
                                        NotPlaced(ReasonCode.PATH_TOO_SHORT, "unused"))
                       for model_id, probability in vote.items())
    vehicle = VehicleSpeed(track_id, 0, 39, FPS, candidates[0].path, candidates[0].speed, candidates=candidates)
    return vehicle.with_candidate(candidates[0], ModelSource.VOTE)


@pytest.mark.parametrize("model_id", [SPIRIOR, MERCEDES_R])
def test_the_box_height_excess_of_the_true_shape_is_the_shadow(model_id: int) -> None:
    centre = np.array([0.0, 30000.0])
    box = _box(model_id, centre)
    height_px = np.ptp(shape_pixels(CAMERA, CLASSIFIER.metadata.shape_of(model_id), centre, -90.0)[:, 1])
    # tolerance: the box's rows are whole pixels, the top and the bottom each within one
    assert box_height_excess(CAMERA, CLASSIFIER.metadata.shape_of(model_id), box, centre, -90.0) == pytest.approx(
        SHADOW, abs=2.0 / height_px)


def test_a_vehicle_voted_a_taller_model_is_given_the_one_its_boxes_fit_and_its_speed() -> None:
    sure = [_vehicle(i, SPIRIOR, x, v, {SPIRIOR: 0.9, MERCEDES_R: 0.05})
            for i, (x, v) in enumerate([(-3500.0, 120.0), (0.0, 90.0), (3500.0, 60.0), (-3300.0, 110.0),
                                        (200.0, 80.0), (3300.0, 50.0)])]
    unsure = _vehicle(10, SPIRIOR, 0.0, 100.0, {MERCEDES_R: 0.55, SPIRIOR: 0.40})
    assert isinstance(unsure.speed, SpeedFit)
    assert unsure.speed.speed_kmh < 100.0 * 0.98  # the roof named 0.2 m too high, 9 m up: the path 2.6 % short
    reference = box_height_reference(sure + [unsure], SpeedParams.from_config())
    assert reference is not None and reference.vehicles == 6
    assert reference.excess == pytest.approx(SHADOW, abs=0.02)  # tolerance: whole-pixel boxes 40-120 px high
    chosen = choose_models(sure + [unsure], SpeedParams.from_config())[-1]
    assert chosen.model_id == SPIRIOR and chosen.model_source == ModelSource.BOX_HEIGHT
    assert chosen.speed.speed_kmh == pytest.approx(100.0, rel=0.005)  # tolerance: whole-pixel box tops
    assert chosen.row()["voted_model_id"] == MERCEDES_R and chosen.row()["model_source"] == "vote and box height"
    assert [v.model_source for v in choose_models(sure, SpeedParams.from_config())] == [ModelSource.VOTE] * 6


def test_with_too_few_sure_vehicles_every_vote_stands() -> None:
    sure = [_vehicle(i, SPIRIOR, x, 90.0, {SPIRIOR: 0.9, MERCEDES_R: 0.05}) for i, x in enumerate([-3500.0, 0.0])]
    unsure = _vehicle(10, SPIRIOR, 0.0, 100.0, {MERCEDES_R: 0.55, SPIRIOR: 0.40})
    params = SpeedParams.from_config()
    assert box_height_reference(sure + [unsure], params) is None
    assert choose_models(sure + [unsure], params)[-1].model_id == MERCEDES_R
    with pytest.raises(ConfigError, match="candidates"):
        SpeedParams.from_config(candidates=0)


def test_a_vehicle_whose_boxes_no_model_fits_says_so() -> None:
    """Boxes twice as tall as the Spirior's (a truck, or two cars in one blob): no frame is within
    `speed.max_box_mismatch` of the model's size, and the vehicle is not measured with that reason, not as a short
    path."""
    frames = np.arange(40)
    centres = np.column_stack([np.zeros(40), 60000.0 - frames / FPS * 25.0 * 1000.0])
    boxes = {}
    for f, c in zip(frames, centres):
        box = _box(SPIRIOR, c)
        boxes[int(f)] = Box(box.x0, box.y0 - box.height_px, box.x1, box.y1)
    bottoms = CAMERA.image_to_road(np.array([[b.centre_px[0], b.y1 - 1.0] for b in boxes.values()]))
    candidate = SPEEDS.candidate(SPIRIOR, 1.0, frames, bottoms, boxes, -90.0,
                                 NotPlaced(ReasonCode.PATH_TOO_SHORT, "unused"))
    assert isinstance(candidate.speed, NotPlaced) and candidate.speed.code == ReasonCode.BOX_NOT_MODEL_SIZE
    assert "none of its 40 boxes" in candidate.speed.message
