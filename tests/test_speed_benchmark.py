"""The speed benchmark's side: flowing traffic whose cars never catch up in their lane, its truth in the benchmark's
format (crossing times exact), the scorer's rules on a system that reports the true positions (no error, every car
matched) and on one that is late or in another lane, the results file read back by the scorer's projection to the
speeds of tracks.csv, and the benchmark's files read and refused in one line."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from bad_input import assert_one_error, run_cli
from scene_configs import traffic_scene

from vehloc.geometry.brno import brno_calibration, project_to_metres
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.outcome import NotPlaced
from vehloc.geometry.pipeline.brno_files import (
    BrnoCar,
    BrnoFileError,
    BrnoResults,
    read_ground_truth,
    read_results,
    results_json,
)
from vehloc.geometry.pipeline.speed_eval import score_speeds
from vehloc.geometry.pipeline.track_speed import VehiclePath, VehicleSpeed
from vehloc.geometry.speed import SpeedFit, fit_speed
from vehloc.synth.scene import car_pose_at
from vehloc.synth.speed_truth import speed_ground_truth


@pytest.fixture(scope="module")
def scene():
    return traffic_scene("traffic_720p", "scene.traffic.duration_s=40")


@pytest.fixture(scope="module")
def truth_file(scene, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("truth") / "gt_data.json"
    path.write_text(json.dumps(speed_ground_truth(scene, "video.avi")))
    return path


def test_no_car_catches_up_with_the_one_ahead_in_its_lane(scene) -> None:
    assert len(scene.cars) >= 18  # 36 a minute over 40 s, Poisson: at least half that many
    lanes = {}
    for car in scene.cars:
        lanes.setdefault(round(car.target_x_mm / 3500.0), []).append(car)  # lanes at -3500, 0, 3500 mm
    for cars in lanes.values():
        for ahead, behind in zip(cars, cars[1:]):
            enter_gap = (behind.delay_frames - ahead.delay_frames) / scene.fps
            leave_gap = enter_gap + (2 * behind.approach_mm / (behind.speed_kmh / 3.6) - 2 * ahead.approach_mm
                                     / (ahead.speed_kmh / 3.6)) / 1000.0
            assert enter_gap >= 1.5 - 0.04 and leave_gap >= 1.5 - 0.04  # min_headway_s, less a frame's rounding
    speeds = [car.speed_kmh for car in scene.cars]
    assert 30.0 <= min(speeds) and max(speeds) <= 130.0


def test_the_truth_crossing_times_are_where_the_cars_cross_the_lines(scene) -> None:
    truth = speed_ground_truth(scene, "video.avi")
    lines_y = truth["measurement_lines_y_mm"]
    assert lines_y == sorted(lines_y)  # cars come towards the camera (-Y): the nearest line is crossed last, listed first
    for entry in truth["cars"]:
        car = scene.cars[entry["carId"]]
        for crossing in entry["intersections"]:
            frame = crossing["videoTime"] * scene.fps
            before, after = car_pose_at(scene, car, int(np.floor(frame))), car_pose_at(scene, car, int(np.ceil(frame)))
            y_mm = before.y_mm + (after.y_mm - before.y_mm) * (frame - np.floor(frame))  # the motion is linear
            assert y_mm == pytest.approx(lines_y[crossing["measurementLineId"]], abs=1e-6)
        assert entry["speed"] == car.speed_kmh


def _true_system(scene, time_shift_s: float = 0.0, lane_shift_mm: float = 0.0) -> BrnoResults:
    """A system that reports every car's true footprint centre in every frame it is in view."""
    camera = scene.camera.camera()
    cars = []
    for index, car in enumerate(scene.cars):
        frames, points = [], []
        for frame in range(scene.frame_count):
            pose = car_pose_at(scene, car, frame)
            if pose is None or camera.to_camera(np.array([[pose.x_mm, pose.y_mm, 0.0]]))[0, 2] < 1000.0:
                continue
            frames.append(frame + time_shift_s * scene.fps)
            points.append(camera.project(np.array([[pose.x_mm + lane_shift_mm, pose.y_mm, 0.0]]))[0])
        cars.append(BrnoCar(index, np.array(frames), np.array(points).reshape(-1, 2)))
    road = np.array([[x, y] for x in (-5000.0, 5000.0) for y in (10000.0, 40000.0)])
    return BrnoResults(brno_calibration(camera, camera.road_to_image(), road), tuple(cars))


def test_the_true_positions_score_no_error_and_every_car(scene, truth_file: Path) -> None:
    truth = read_ground_truth(truth_file)
    score = score_speeds(_true_system(scene), truth, (1280, 720), "median")
    assert score.recall == 1.0 and score.precision == 1.0 and score.false_positives == 0
    assert score.errors_kmh.max() < 1e-6  # exact positions, exact speeds
    full = score_speeds(_true_system(scene), truth, (1280, 720), "full")
    # the line crossings interpolated from the 6 nearest points, in the image: perspective bends the time-distance
    # relation, by well under 1 %
    assert full.recall == 1.0 and np.median(full.relative_errors_percent) < 1.0
    assert max(abs(e) for e in score.distance_errors_m) < 1e-6  # the scale turns the truth's distances into metres


def test_a_late_system_or_one_in_the_wrong_lane_is_not_matched(scene, truth_file: Path) -> None:
    truth = read_ground_truth(truth_file)
    late = score_speeds(_true_system(scene, time_shift_s=0.3), truth, (1280, 720))
    assert late.recall == 0.0 and late.false_positives > 0  # crossing the last line 0.3 s late: beyond 0.2 s
    shifted = score_speeds(_true_system(scene, lane_shift_mm=3500.0), truth, (1280, 720))
    assert shifted.recall < 0.5  # a lane to the right: matched only where the truth's lane holds it


def test_the_results_file_reads_back_to_the_speeds_of_the_tracks(scene, tmp_path: Path) -> None:
    camera = scene.camera.camera()
    calibration = CameraCalibration.from_homography(camera.road_to_image().matrix, (1280, 720), 0.5, "truth")
    vehicles = []
    for index, car in enumerate(scene.cars[:6]):
        frames = np.array([f for f in range(scene.frame_count) if (pose := car_pose_at(scene, car, f)) is not None
                           and pose.y_mm > 6000.0])
        points = np.array([[car_pose_at(scene, car, f).x_mm, car_pose_at(scene, car, f).y_mm] for f in frames])
        points = points + np.random.default_rng(index).normal(0.0, 50.0, points.shape)
        speed = fit_speed(points, frames / scene.fps, 0.0, 6, 3000.0)
        assert isinstance(speed, SpeedFit)
        vehicles.append(VehicleSpeed(index + 1, int(frames[0]), int(frames[-1]), scene.fps,
                                     VehiclePath(frames, points, calibration.road_to_image(points),
                                                                np.zeros((len(frames), 4), int)), speed))
    block = brno_calibration(calibration.camera, calibration.road_to_image, np.concatenate([v.path.points_mm for v in vehicles]))
    path = tmp_path / "system_vehloc.json"
    path.write_text(results_json(vehicles, block, calibration.camera.road_to_image(), "video.avi", (1280, 720), 25.0))
    results = read_results(path)
    for vehicle, car in zip(vehicles, results.cars):
        metres = project_to_metres(car.points_px, results.calibration)
        # the scorer's world is 3D: its road plane is tilted, so the fit is on the plane's own two axes
        basis = np.linalg.svd(metres - metres.mean(axis=0), full_matrices=False)[2][:2]
        again = fit_speed((metres - metres.mean(axis=0)) @ basis.T * 1000.0, car.frames / scene.fps, 0.0, 6, 3000.0)
        assert not isinstance(again, NotPlaced)
        assert again.speed_kmh == pytest.approx(vehicle.speed.speed_kmh, rel=0.001)  # the 0.1 %


def test_the_results_report_the_steady_motion_where_the_followed_box_holds_it(scene) -> None:
    """A car measured in frames 0-19 and 41-59; in frames 20-40 its box merged with another's (no used point, the box
    holds it), in 60-69 its track went on to another vehicle (a box far from it): the results report its steady
    motion through 20-40, exact for a car at a constant speed (1e-6 mm), and nothing in 60-69."""
    camera = scene.camera.camera()
    calibration = CameraCalibration.from_homography(camera.road_to_image().matrix, (1280, 720), 0.5, "truth")
    frames = np.arange(70)
    truth_mm = np.column_stack([np.full(70, 1750.0), 60000.0 - 1000.0 * frames])  # 90 km/h at 25 fps
    pixels = calibration.road_to_image(truth_mm)
    boxes = np.column_stack([pixels - 40.0, pixels + 40.0]).astype(int)
    boxes[60:] = [1000, 50, 1100, 120]
    measured = np.r_[0:20, 41:60]
    speed = fit_speed(truth_mm[measured], measured / 25.0, 0.0, 6, 3000.0)
    assert isinstance(speed, SpeedFit) and speed.speed_kmh == pytest.approx(90.0)
    vehicle = VehicleSpeed(1, 0, 69, 25.0, VehiclePath(measured, truth_mm[measured], pixels[measured], boxes[measured]),
                           speed, seen_frames=frames, seen_boxes_px=boxes)
    reported, points_mm = vehicle.reported(calibration.road_to_image)
    assert reported.tolist() == list(range(60))
    assert np.abs(points_mm - truth_mm[:60]).max() < 1e-6
    rows = vehicle.trajectory_rows(calibration.road_to_image)
    assert [r["frame"] for r in rows if r["predicted"]] == list(range(20, 41))
    assert all(r["used"] for r in rows if not r["predicted"]) and len(rows) == 60


def test_the_benchmark_pickle_is_read_as_the_scorer_reads_it(truth_file: Path, tmp_path: Path) -> None:
    content = json.loads(truth_file.read_text())
    pickled = tmp_path / "gt_data.pkl"
    pickled.write_bytes(pickle.dumps(content | {"cars": [car | {"laneIndex": set(car["laneIndex"])}
                                                        for car in content["cars"]]}, protocol=2))
    assert read_ground_truth(pickled).cars == read_ground_truth(truth_file).cars
    del content["cars"][3]["speed"]
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps(content))
    with pytest.raises(BrnoFileError, match=r"broken.json: cars\[3\].speed is missing"):
        read_ground_truth(broken)


def test_the_scorer_refuses_another_frame_rate_and_another_video_in_one_line(scene, truth_file: Path,
                                                                              tmp_path: Path) -> None:
    results = tmp_path / "system_vehloc.json"
    system = _true_system(scene)
    results.write_text(json.dumps({"camera_calibration": system.calibration.to_json(), "video": "other.avi",
                                   "cars": [{"id": c.car_id, "frames": c.frames.tolist(), "posX": c.points_px[:, 0].tolist(),
                                             "posY": c.points_px[:, 1].tolist()} for c in system.cars]}))
    other = run_cli("vehloc-speed-eval", results, truth_file, "--out", tmp_path / "score")
    assert_one_error(other, "vehloc-speed-eval", "results of other.avi", "video.avi")
    results.write_text(results.read_text().replace('"other.avi"', '"video.avi"'))
    fps = run_cli("vehloc-speed-eval", results, truth_file, "--out", tmp_path / "score", "--fps", "30")
    assert_one_error(fps, "vehloc-speed-eval", "fps is 25", "the video's is 30")
    results.write_text(results.read_text().replace('"video": "video.avi"', '"video": "video.avi", "fps": 50.0'))
    stated = run_cli("vehloc-speed-eval", results, truth_file, "--out", tmp_path / "score")  # the results file's own
    assert_one_error(stated, "vehloc-speed-eval", "fps is 25", "the video's is 50")
    results.write_text(results.read_text().replace('"fps": 50.0', '"fps": 25.0'))
    negative = run_cli("vehloc-speed-eval", results, truth_file, "--out", tmp_path / "score", "--fps", "-5")
    assert_one_error(negative, "vehloc-speed-eval", "--fps", "above 0, got -5", code=2)
    scored = run_cli("vehloc-speed-eval", results, truth_file, "--out", tmp_path / "score")
    assert scored.returncode == 0, scored.stderr[-2000:]
    assert "recall 1.000, precision 1.000" in scored.stdout
    assert {p.name for p in (tmp_path / "score").iterdir()} >= {"matches.csv", "speed_eval.md", "speed_eval.csv",
                                                                 "speed_eval.png"}
