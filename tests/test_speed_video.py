"""Speeds end to end: twenty seconds of rendered traffic of one catalog model, the camera calibrated from its markers,
every vehicle tracked and its speed measured with the true model named, scored against the scene's truth with the
benchmark's rules; the results file read back by the scorer's projection gives the speeds of tracks.csv."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from bad_input import run_cli

from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.geometry.brno import project_to_metres
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.brno_files import BrnoCar, read_ground_truth, read_results
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.speed_eval import score_speeds
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.geometry.speed import fit_speed

pytestmark = pytest.mark.slow  # renders 700 frames at 1280x720 and localizes them (about 30 s)

MODEL_ID = 3


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("traffic")
    scene = folder / "scene"
    rendered = run_cli("vehloc-scene", "scene=traffic_720p", f"out={scene}", "scene.traffic.duration_s=20",
                       f"+scene.traffic.model_ids=[{MODEL_ID}]", "scene.traffic.seed=7", cwd=folder)
    assert rendered.returncode == 0, rendered.stderr[-2000:]
    calibrated = run_cli("vehloc-calibrate", f"site={scene / 'site.yaml'}", f"image={scene / 'video.avi'}",
                         f"hydra.run.dir={folder / 'calibration'}", cwd=folder)
    assert calibrated.returncode == 0, calibrated.stderr[-2000:]
    localizer = Localizer(TrueModelClassifier(MODEL_ID), read_calibration(folder / "calibration" / "calibration.json"),
                          LocalizeSettings.compose(["experiment=traffic"]))
    localize_video(localizer, scene / "video.avi", folder / "run", pictures=True, progress=False)
    return {"scene": scene, "run": folder / "run"}


def test_every_car_is_measured_within_a_kilometre_an_hour(run: dict[str, Path]) -> None:
    truth = read_ground_truth(run["scene"] / "gt_data.json")
    score = score_speeds(read_results(run["run"] / "system_vehloc.json"), truth, (1280, 720))
    assert len(truth.cars) >= 8
    assert score.recall == 1.0 and score.precision == 1.0
    # the bars of rendered traffic at 1280x720 with the model named right: median 0.5 km/h, worst 2 km/h
    assert np.median(score.errors_kmh) <= 0.5 and score.errors_kmh.max() <= 2.0


def test_the_results_file_gives_the_speeds_of_tracks_csv(run: dict[str, Path]) -> None:
    tracks = pd.read_csv(run["run"] / "tracks.csv").set_index("track_id")
    results = read_results(run["run"] / "system_vehloc.json")
    fps = json.loads((run["scene"] / "ground_truth.json").read_text())["fps"]
    trajectories = pd.read_csv(run["run"] / "trajectories.csv")
    assert len(results.cars) == tracks["speed_kmh"].notna().sum()
    for car in results.cars:
        # the frames its speed used (the others report its steady motion, where it was followed without a point)
        used = trajectories[(trajectories["track_id"] == car.car_id) & trajectories["used"]]["frame"].to_numpy()
        assert set(used) <= set(car.frames.tolist())
        kept = np.isin(car.frames, used)
        car = BrnoCar(car.car_id, car.frames[kept], car.points_px[kept])
        metres = project_to_metres(car.points_px, results.calibration)
        basis = np.linalg.svd(metres - metres.mean(axis=0), full_matrices=False)[2][:2]  # the road plane's own axes
        again = fit_speed((metres - metres.mean(axis=0)) @ basis.T * 1000.0, car.frames / fps, 0.0, 6, 0.0)
        assert again.speed_kmh == pytest.approx(tracks.loc[car.car_id, "speed_kmh"], rel=0.001)  # the 0.1 %


def test_the_files_hold_one_row_per_vehicle_and_one_per_vehicle_and_frame(run: dict[str, Path]) -> None:
    tracks = pd.read_csv(run["run"] / "tracks.csv")
    trajectories = pd.read_csv(run["run"] / "trajectories.csv")
    measured = tracks[tracks["status"] == "measured"]
    assert set(trajectories["track_id"]) >= set(measured["track_id"])
    assert (measured["model_id"] == MODEL_ID).all() and measured["lane"].notna().all()
    assert set(measured["lane"]) <= {0, 1, 2}
    assert (trajectories.groupby("track_id")["used"].sum().loc[measured["track_id"]].values == measured["points"].values).all()
    assert (measured["sigma_kmh"] > 0).all() and (run["run"] / "speeds.png").stat().st_size > 0


def test_a_few_frames_show_each_vehicle_with_its_id_and_speed(run: dict[str, Path]) -> None:
    import cv2

    pictures = sorted(run["run"].glob("speeds_frame*.png"))
    assert 1 <= len(pictures) <= 4
    frames = [int(p.stem.removeprefix("speeds_frame")) for p in pictures]
    trajectories = pd.read_csv(run["run"] / "trajectories.csv")
    tracks = pd.read_csv(run["run"] / "tracks.csv")
    measured = trajectories["track_id"].isin(tracks.loc[tracks["status"] == "measured", "track_id"])
    busiest = trajectories[measured & trajectories["used"]].groupby("frame").size()
    assert busiest.loc[frames[0]] >= 1 and max(busiest.loc[f] for f in frames) == busiest.max()
    image = cv2.imread(str(pictures[0]))
    assert image.shape == (720, 1280, 3)


def test_the_camera_calibrated_by_its_traffic_alone(run: dict[str, Path]) -> None:
    """No markers, no site: the vanishing points from the vehicles' paths and edges, the scale from their (true)
    model's shape fitted to their boxes, against the scene's true camera."""
    from vehloc.geometry.pipeline.auto_calibrate import AutoCalibrationParams, auto_calibrate, collect_traffic, recognised_models
    from vehloc.geometry.truth import read_scene_truth

    params = AutoCalibrationParams.from_config(min_vehicles=5)
    settings = LocalizeSettings.compose(["experiment=traffic"])
    evidence = collect_traffic(run["scene"] / "video.avi", params, settings, progress=False)
    result = auto_calibrate(evidence, recognised_models(TrueModelClassifier(MODEL_ID), "expected"), params,
                            settings.pipeline.border_margin_px)
    truth = read_scene_truth(run["scene"] / "ground_truth.json").camera
    assert result, str(result)
    assert result.scale.vehicles >= 5
    # the development scene's figures are 1.1 % (focal) and 1.5 % (height): within 3 % here
    assert abs(result.focal_px / truth.focal_px - 1.0) < 0.03
    assert abs(result.scale.height_mm / truth.centre_mm[2] - 1.0) < 0.03
    # road distances along the middle lane's measured stretch, through the true camera's pixels: within 3 %
    road = np.array([[0.0, y] for y in (14000.0, 26000.0, 38000.0)])
    back = result.camera.image_to_road(truth.road_to_image()(road))
    assert np.allclose(np.linalg.norm(np.diff(back, axis=0), axis=1), 12000.0, rtol=0.03)
    # the lens's focal length given: the same road, with the edges telling only the horizon's direction
    given = auto_calibrate(evidence, recognised_models(TrueModelClassifier(MODEL_ID), "expected"),
                           AutoCalibrationParams.from_config(min_vehicles=5, focal_px=truth.focal_px),
                           settings.pipeline.border_margin_px)
    assert given.focal_source == "given" and given.focal_px == truth.focal_px and given.focal_sigma_px == 0.0
    assert abs(given.scale.height_mm / truth.centre_mm[2] - 1.0) < 0.03
    # too few vehicles for the scale: refused with its reason, not a calibration
    refused = auto_calibrate(evidence, recognised_models(TrueModelClassifier(MODEL_ID), "expected"),
                             AutoCalibrationParams.from_config(min_vehicles=1000), settings.pipeline.border_margin_px)
    assert not refused and f"{result.scale.vehicles} vehicle(s) could be scaled by their model, 1000 needed" in str(refused)
