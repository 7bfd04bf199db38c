"""Traffic scenes: configs, the cars' motion, exact ground truth of every car, several cars in one frame,
and the site file made for the scenes."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scene_configs import PLATE_SCENES, SIDE_ON_SCENES, scene_spec, short_scene

from vehloc.config import ConfigError
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.synth.body import build_car_mesh
from vehloc.synth.noise import SensorNoise, uniform_16bit
from vehloc.synth.render import CarPose, Lighting, plates_seen, render_car
from vehloc.synth.road import render_road
from vehloc.synth.scene import SceneSpec, car_pose_at, draw_cars, render_frames, write_scene
from vehloc.synth.scene_site import scene_site

PAPER_TABLE2_REAL_POSES = {
    "table2_middle_0": (404, 10530, -3.76), "table2_middle_30": (456, 9706, 16.95),
    "table2_middle_minus30": (76, 11087, -32.71), "table2_close_0": (194, 4060, -2.07),
    "table2_close_30": (548, 4147, 23.92), "table2_close_minus30": (-181, 3958, -26.30),
}


def _lighting(spec: SceneSpec) -> Lighting:
    return Lighting.from_angles(spec.light_azimuth_deg, spec.light_elevation_deg, 0.45, 0.6)


def _blank(spec: SceneSpec) -> np.ndarray:
    return np.zeros((spec.camera.height_px, spec.camera.width_px, 3), np.uint8)


def _vertices_px(spec: SceneSpec, car_index: int, pose: CarPose) -> np.ndarray:
    car = spec.cars[car_index]
    return spec.camera.camera().project(pose.car_to_world(build_car_mesh(car.model).vertices_mm))


@pytest.mark.parametrize("name", SIDE_ON_SCENES)
def test_table2_configs_compose_with_the_paper_poses(name: str) -> None:
    spec = scene_spec(name)
    (car,) = spec.cars
    assert (car.target_x_mm, car.target_y_mm, car.target_heading_deg) == PAPER_TABLE2_REAL_POSES[name]
    assert car.model_id == 9 and car.stops and car.delay_frames == 0 and spec.empty_frames >= 150
    assert (spec.camera.width_px, spec.camera.height_px) == (1280, 720)


def test_a_spec_survives_its_plain_mapping() -> None:
    spec = scene_spec("two_cars")
    assert SceneSpec.from_dict(dataclasses.asdict(spec)) == spec


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda v: v.update(speed=3), r"^scene: unknown setting\(s\) speed "),
        (lambda v: v["cars"][0].update(wheels=4), r"^scene\.cars\[0\]: unknown setting\(s\) wheels "),
        (lambda v: v["cars"][1].update(stops="yes"), r"^scene\.cars\[1\]\.stops: expected true or false, got 'yes'$"),
        (lambda v: v["cars"][1].update(model_id=99), r"^scene\.cars\[1\]: model_id 99 is not a catalog model"),
        (lambda v: v["cars"][0].pop("approach_mm"), r"^scene\.cars\[0\]: missing setting\(s\) approach_mm$"),
        (lambda v: v.update(cars=[]), r"^scene: cars: a scene needs at least one car$"),
        (lambda v: v.update(codec="h264"), r"^scene: codec must be one of"),
    ],
    ids=["unknown", "unknown_car_setting", "stops_not_bool", "model_id", "missing", "no_car", "codec"],
)
def test_bad_scene_settings_are_named_in_one_line(change: Callable[[dict], object], message: str) -> None:
    values = dataclasses.asdict(scene_spec("two_cars"))
    change(values)
    with pytest.raises(ConfigError, match=message):
        SceneSpec.from_dict(values)


def test_a_stopping_car_decelerates_to_its_target_pose() -> None:
    spec = scene_spec("table2_close_30", empty_frames=5, drive_frames=10)
    car = dataclasses.replace(spec.cars[0], target_x_mm=500.0, target_y_mm=9000.0, target_heading_deg=30.0)
    spec = dataclasses.replace(spec, cars=(car,))
    assert car_pose_at(spec, car, 4) is None
    start = car_pose_at(spec, car, 5)
    assert np.hypot(start.x_mm - 500, start.y_mm - 9000) == pytest.approx(car.approach_mm)
    assert np.degrees(np.arctan2(9000 - start.y_mm, 500 - start.x_mm)) == pytest.approx(30)
    poses = [car_pose_at(spec, car, f) for f in range(5, 16)]
    steps = [np.hypot(b.x_mm - a.x_mm, b.y_mm - a.y_mm) for a, b in zip(poses, poses[1:])]
    assert all(a > b for a, b in zip(steps, steps[1:]))
    assert spec.stop_frame(car) == 15
    assert car_pose_at(spec, car, 15) == car_pose_at(spec, car, spec.frame_count - 1) == car.target_pose


def test_a_passing_car_keeps_its_speed_crosses_its_target_at_mid_time_and_leaves() -> None:
    """Steps between frames equal 2 approach_mm / drive_frames along the heading (tolerance 1e-9 mm); at
    its last pose the car is out of view, and then out of the scene."""
    spec = scene_spec("two_cars")
    car = spec.cars[1]
    entry = spec.entry_frame(car)
    assert not car.stops and spec.stop_frame(car) is None and entry == spec.empty_frames + car.delay_frames
    assert car_pose_at(spec, car, entry - 1) is None
    assert car_pose_at(spec, car, entry + spec.drive_frames + 1) is None
    poses = [car_pose_at(spec, car, f) for f in range(entry, entry + spec.drive_frames + 1)]
    assert all(p is not None and p.heading_deg == car.target_heading_deg for p in poses)
    steps = np.diff([[p.x_mm, p.y_mm] for p in poses], axis=0)
    heading = np.radians(car.target_heading_deg)
    expected = 2 * car.approach_mm / spec.drive_frames * np.array([np.cos(heading), np.sin(heading)])
    np.testing.assert_allclose(steps, np.tile(expected, (len(steps), 1)), atol=1e-9)
    assert poses[spec.drive_frames // 2] == car.target_pose
    camera = spec.camera.camera()
    for pose, in_view in ((poses[0], True), (poses[-1], False)):
        _, boxes = draw_cars(spec.cars, (None, pose), camera, _blank(spec), _lighting(spec))
        assert (boxes[1] is not None) == in_view


def test_ground_truth_of_every_car_is_exact(tmp_path: Path) -> None:
    """Footprint centred on the target pose (tolerance 1e-6 mm), L x W, front towards the heading (1e-9
    deg); tyre contacts and footprint corners in the image are the world ones through the road homography
    (1e-6 px); per-frame poses are those of the motion, boxes null before a car enters."""
    spec = short_scene("two_cars")
    video, truth_path = write_scene(spec, tmp_path)
    truth = json.loads(truth_path.read_text())
    assert "car" not in truth and len(truth["cars"]) == 2
    assert truth["frames"] == spec.frame_count == 21 == len(list(iter_frames(video)))
    homography = ProjectiveTransform.road_to_image(np.array(truth["homography_world_mm_to_image_px"]), 1280, 720)
    for car, entry in zip(spec.cars, truth["cars"]):
        x_mm, y_mm, heading_deg = car.target_x_mm, car.target_y_mm, car.target_heading_deg
        assert entry["model_id"] == car.model_id and entry["stops"] == car.stops
        assert entry["target_pose"] == {"x_mm": x_mm, "y_mm": y_mm, "heading_deg": heading_deg}
        footprint = np.array(entry["footprint_corners_mm"])
        np.testing.assert_allclose(footprint.mean(axis=0), [x_mm, y_mm], atol=1e-6)
        assert np.linalg.norm(footprint[0] - footprint[3]) == pytest.approx(entry["length_mm"], abs=1e-6)
        assert np.linalg.norm(footprint[0] - footprint[1]) == pytest.approx(entry["width_mm"], abs=1e-6)
        front_mid = (footprint[0] + footprint[1]) / 2 - [x_mm, y_mm]
        turn_deg = np.degrees(np.arctan2(front_mid[1], front_mid[0])) - heading_deg
        assert (turn_deg + 180) % 360 - 180 == pytest.approx(0, abs=1e-9)
        tyres = np.array(entry["tyre_contacts_mm"])
        axle_gap_mm = np.linalg.norm((tyres[0] + tyres[1]) / 2 - (tyres[2] + tyres[3]) / 2)
        assert axle_gap_mm == pytest.approx(entry["wheelbase_mm"], abs=1e-6)
        np.testing.assert_allclose(homography(tyres), entry["tyre_contacts_px"], atol=1e-6)
        np.testing.assert_allclose(homography(footprint), entry["footprint_corners_px"], atol=1e-6)
        first, held = entry["per_frame_from"], len(entry["poses"])  # the frames from its entry to its leaving
        motion = [car_pose_at(spec, car, f) for f in range(spec.frame_count)]
        assert first == entry["entry_frame"] and all(p is None for p in motion[:first] + motion[first + held:])
        assert entry["poses"] == [None if p is None else {"x_mm": p.x_mm, "y_mm": p.y_mm, "heading_deg": p.heading_deg}
                                  for p in motion[first:first + held]]
        assert len(entry["boxes_xyxy_px"]) == held
        assert all(box is None for box, pose in zip(entry["boxes_xyxy_px"], entry["poses"]) if pose is None)
    stopping, passing = truth["cars"]
    assert (stopping["entry_frame"], stopping["stop_frame"], passing["entry_frame"], passing["stop_frame"]) == (1, 5, 16, None)
    assert len(stopping["poses"]) == spec.frame_count - 1  # it stays to the end
    assert stopping["boxes_xyxy_px"][-1] is not None and passing["boxes_xyxy_px"][0] is not None
    assert passing["poses"][4] is not None and passing["boxes_xyxy_px"][4] is None  # frame 20: left the view
    marker = next(m for m in truth["markers"] if m["has_corners"] and None not in m["corners_px"])
    np.testing.assert_allclose(homography(np.array(marker["corners_mm"])), marker["corners_px"], atol=1e-6)
    np.testing.assert_allclose(truth["camera"]["centre_mm"], spec.camera.camera().centre_mm, atol=1e-9)


def test_two_cars_have_their_own_boxes_and_the_nearer_is_drawn_over_the_farther() -> None:
    """While the passing car goes by behind the stopped one, each car's box is where its projected mesh is
    (within 2 px) and is the box of that car rendered alone, and the pixels the nearer car covers wholly
    show the nearer car."""
    spec = scene_spec("two_cars")
    frame = spec.entry_frame(spec.cars[1]) + 37  # the passing car 6.4 m up the road, partly behind the stopped one
    poses = tuple(car_pose_at(spec, car, frame) for car in spec.cars)
    camera, lighting = spec.camera.camera(), _lighting(spec)
    road = render_road(camera, spec.layout, np.random.default_rng(spec.seed))
    image, boxes = draw_cars(spec.cars, poses, camera, road, lighting)
    alone = [render_car(car.model, car.paint[1], pose, camera, road, lighting) for car, pose in zip(spec.cars, poses)]
    assert boxes == tuple(render.box for render in alone)
    for index, box in enumerate(boxes):
        vertices = _vertices_px(spec, index, poses[index])
        np.testing.assert_allclose(box.as_tuple(), [*vertices.min(axis=0), *vertices.max(axis=0) + 1], atol=2)
    assert boxes[0].intersection(boxes[1]).area_px > 1000
    near, far = alone  # the stopped car stands nearer the camera
    hidden = (near.coverage == 1.0) & far.mask
    assert hidden.sum() > 100
    assert np.array_equal(image[hidden], near.image_bgr[hidden])


def test_the_cut_scene_stops_its_car_across_the_image_edge() -> None:
    spec = scene_spec("cut_by_edge")
    (car,) = spec.cars
    _, (box,) = draw_cars(spec.cars, (car.target_pose,), spec.camera.camera(), _blank(spec), _lighting(spec))
    assert box is not None and box.touches_border(1280, 720) and box.y1 == 720
    assert _vertices_px(spec, 0, car.target_pose)[:, 1].max() > 720 + 50  # a good part of the car is below the edge


@pytest.mark.parametrize("name", PLATE_SCENES)
def test_plate_scenes_show_a_plate_of_30_px_with_the_car_wholly_in_view(name: str) -> None:
    """The car stands along the road (heading -90 front first, 90 rear first) turned 0 or +-30 deg, at
    about 8.5 m (middle) or 4 m (close); the plate towards the camera faces it and is >= 30 px wide."""
    spec = scene_spec(name)
    (car,) = spec.cars
    distance, angle = name.removeprefix("table2_plate_").split("_")
    end, axis_deg = ("front", -90.0) if distance == "middle" else ("rear", 90.0)
    assert car.target_heading_deg == axis_deg + {"0": 0.0, "30": 30.0, "minus30": -30.0}[angle]
    assert abs(car.target_y_mm - {"middle": 9000.0, "close": 4000.0}[distance]) <= 1000.0
    plate = plates_seen(car.model, car.target_pose, spec.camera.camera())[end]
    assert plate.faces_camera
    assert np.linalg.norm(plate.corners_px[1] - plate.corners_px[0]) >= 30.0
    vertices = _vertices_px(spec, 0, car.target_pose)
    assert vertices.min() > 0 and vertices[:, 0].max() < 1279 and vertices[:, 1].max() < 719
    _, (box,) = draw_cars(spec.cars, (car.target_pose,), spec.camera.camera(), _blank(spec), _lighting(spec))
    assert box is not None and not box.touches_border(1280, 720)


def test_stopped_frames_repeat_the_rendered_cars_with_fresh_noise() -> None:
    spec = short_scene("table2_middle_0", drive_frames=2, stopped_frames=2)
    frames = list(render_frames(spec))
    (last_a, boxes_a), (last_b, boxes_b) = frames[-2], frames[-1]
    assert boxes_a == boxes_b and boxes_a[0] is not None
    difference = last_a.astype(float) - last_b
    assert 1.0 < difference.std() < 4.0  # two frames of sensor noise (sigma 2 each), same content


def test_sensor_noise_is_fresh_gaussian_noise_of_the_requested_sigma() -> None:
    """Like float noise added and truncated: mean offset -0.5 and standard deviation sqrt(sigma^2 + 1/12)
    (within 0.01 grey level and 1 %), clipped at 0 and 255, and two frames' noise uncorrelated (|r| < 0.01)."""
    noise = SensorNoise(2.0, np.random.default_rng(0))
    grey = np.full((360, 640, 3), 100, np.uint8)
    first, second = (noise(grey).astype(float) - 100 for _ in range(2))
    assert first.mean() == pytest.approx(-0.5, abs=0.01)
    assert first.std() == pytest.approx(np.sqrt(4 + 1 / 12), rel=0.01)
    assert abs(np.corrcoef(first.ravel(), second.ravel())[0, 1]) < 0.01
    assert noise(np.zeros((2, 2), np.uint8)).dtype == np.uint8
    assert noise(np.full((100, 100), 255, np.uint8)).max() == 255 and noise(np.zeros((100, 100), np.uint8)).min() == 0


def test_scene_site_guess_is_close_to_the_truth() -> None:
    spec = scene_spec("table2_middle_30")
    site = scene_site(spec, click_noise_px=2.0, seed=0)
    truth = spec.camera.camera().road_to_image()
    world = np.array([w for w, _ in site.guess_points])
    error_px = site.initial_transform()(world) - truth(world)
    assert np.all(np.linalg.norm(error_px, axis=1) < 10.0)
    assert len(site.markers) == sum(m.has_corners for m in spec.layout.markers())


@pytest.mark.parametrize("pending_halves", [0, 1])
@pytest.mark.parametrize("shape", [(72, 128, 3), (3, 5)])
def test_uniform_16bit_draws_are_the_generators_own(pending_halves: int, shape: tuple[int, ...]) -> None:
    """Exactly `Generator.integers(0, 65536, dtype=np.uint16)`'s draws, twice, and the same draws after them, with
    and without a 32-bit half pending and with a count that is (72 x 128 x 3) or is not (3 x 5) a multiple of four."""
    drawn, read = np.random.default_rng(11), np.random.default_rng(11)
    for rng in (drawn, read):
        rng.integers(0, 2**32, pending_halves, dtype=np.uint32)
    for _ in range(2):
        np.testing.assert_array_equal(uniform_16bit(read, shape), drawn.integers(0, 65536, shape, dtype=np.uint16))
    np.testing.assert_array_equal(read.integers(0, 2**32, 5, dtype=np.uint32),
                                  drawn.integers(0, 2**32, 5, dtype=np.uint32))
