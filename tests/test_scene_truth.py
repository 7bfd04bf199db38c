"""The typed reader of a scene's ground truth: a written scene read back exactly, and clear errors."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scene_configs import short_scene

from vehloc.data.boxes import Box
from vehloc.geometry.truth import RoadPose, SceneTruthError, read_scene_truth
from vehloc.synth.render import footprint_car_mm, plates_seen, tyre_contacts_car_mm
from vehloc.synth.scene import SceneSpec, car_pose_at, render_frames, write_scene


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[SceneSpec, Path, list[tuple[Box | None, ...]]]:
    spec = short_scene("two_cars")
    _, truth_path = write_scene(spec, tmp_path_factory.mktemp("two_cars"))
    return spec, truth_path, [boxes for _, boxes in render_frames(spec)]


def test_a_written_scene_reads_back_exactly(written: tuple[SceneSpec, Path, list]) -> None:
    """Camera, timing, every car's identity, target pose, points, plates, poses and boxes equal those of
    the spec, the camera and the render exactly (no tolerance: JSON keeps float64 values)."""
    spec, path, rendered = written
    truth = read_scene_truth(path)
    camera = spec.camera.camera()
    for name in ("K", "R", "t"):
        assert np.array_equal(getattr(truth.camera, name), getattr(camera, name))
    assert (truth.camera.width_px, truth.camera.height_px) == (camera.width_px, camera.height_px)
    assert (truth.name, truth.fps, truth.frame_count, truth.empty_frames) == (
        spec.name, spec.fps, spec.frame_count, spec.empty_frames)
    assert len(truth.cars) == len(spec.cars) == 2
    for index, (car_spec, car) in enumerate(zip(spec.cars, truth.cars)):
        model, pose = car_spec.model, car_spec.target_pose
        assert (car.model_id, car.make, car.model) == (model.model_id, model.make, model.name)
        assert (car.length_mm, car.width_mm, car.height_mm, car.wheelbase_mm) == (
            model.length_mm, model.width_mm, model.height_mm, model.wheelbase_mm)
        assert car.axle_middle_x_mm == (model.front_axle_x_mm + model.rear_axle_x_mm) / 2
        assert (car.stops, car.entry_frame, car.stop_frame) == (
            car_spec.stops, spec.entry_frame(car_spec), spec.stop_frame(car_spec))
        assert car.target_pose == RoadPose(car_spec.target_x_mm, car_spec.target_y_mm, car_spec.target_heading_deg)
        assert np.array_equal(car.tyre_contacts_mm, pose.car_to_world(tyre_contacts_car_mm(model))[:, :2])
        assert np.array_equal(car.footprint_corners_mm, pose.car_to_world(footprint_car_mm(model))[:, :2])
        for end, plate in plates_seen(model, pose, camera).items():
            assert np.array_equal(car.plates[end].corners_mm, plate.corners_mm)
            assert np.array_equal(car.plates[end].corners_px, plate.corners_px)
            assert car.plates[end].faces_camera == plate.faces_camera
        motion = (car_pose_at(spec, car_spec, frame) for frame in range(spec.frame_count))
        assert car.poses == tuple(None if p is None else RoadPose(p.x_mm, p.y_mm, p.heading_deg) for p in motion)
        assert car.boxes == tuple(boxes[index] for boxes in rendered)
        assert any(box is not None for box in car.boxes)


def _edited(path: Path, tmp_path: Path, edit: Callable[[dict], object]) -> Path:
    truth = json.loads(path.read_text())
    edit(truth)
    edited = tmp_path / "ground_truth.json"
    edited.write_text(json.dumps(truth))
    return edited


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.pop("camera"), "missing key camera$"),
        (lambda t: t["cars"][0].pop("stop_frame"), r"missing key cars\[0\]\.stop_frame$"),
        (lambda t: t["cars"][1]["plates"].pop("rear"), r"missing key cars\[1\]\.plates\.rear$"),
        (lambda t: t["cars"][1]["target_pose"].pop("y_mm"), r"missing key cars\[1\]\.target_pose\.y_mm$"),
        (lambda t: t["cars"][1]["boxes_xyxy_px"].extend([None] * t["frames"]),
         r"bad value of cars\[1\]\.boxes_xyxy_px: expected a list of at most \d+ frames from frame \d+$"),
        (lambda t: t["cars"][0].update(stops="yes"), r"bad value of cars\[0\]\.stops: expected true or false, got 'yes'$"),
        (lambda t: t["camera"].update(K=[[1, 0], [0, 1]]), r"bad value of camera\.K: expected shape \(3, 3\), got \(2, 2\)$"),
        (lambda t: t.update(cars=[]), "cars must be a non-empty list$"),
    ],
    ids=["camera", "stop_frame", "plate", "pose_key", "frames", "stops", "K", "no_cars"],
)
def test_a_bad_file_is_named_with_the_key(
    written: tuple[SceneSpec, Path, list], tmp_path: Path, edit: Callable[[dict], object], message: str
) -> None:
    edited = _edited(written[1], tmp_path, edit)
    with pytest.raises(SceneTruthError, match=message) as error:
        read_scene_truth(edited)
    assert str(error.value).startswith(f"{edited}: ") and "\n" not in str(error.value)


def test_a_missing_or_unreadable_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(SceneTruthError, match="none.json: scene ground truth does not exist"):
        read_scene_truth(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(SceneTruthError, match="bad.json: not a JSON file"):
        read_scene_truth(tmp_path / "bad.json")
