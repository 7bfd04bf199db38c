"""`vehloc-scene` and `vehloc-calibrate` end to end, and their errors on bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from scene_configs import scene_spec

from vehloc.atomic import write_text
from vehloc.geometry.site import site_yaml
from vehloc.data.preprocess import ImageInputError
from vehloc.geometry.pipeline.video import MediaError, iter_frames, median_background, read_still
from vehloc.synth.road import render_road
from vehloc.synth.scene_site import scene_site


def _run(module: str, *overrides: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", module, *overrides], capture_output=True, text=True)


@pytest.fixture(scope="module")
def road_and_site(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("site")
    spec = scene_spec("table2_middle_0")
    cv2.imwrite(str(folder / "road.png"), render_road(spec.camera.camera(), spec.layout, np.random.default_rng(0)))
    write_text(folder / "site.yaml", site_yaml(scene_site(spec)))
    return folder / "road.png", folder / "site.yaml"


def test_calibrate_writes_calibration_and_overlay(road_and_site: tuple[Path, Path], tmp_path: Path) -> None:
    image, site = road_and_site
    run = _run("vehloc.geometry.pipeline.calibrate_cli", f"site={site}", f"image={image}", f"hydra.run.dir={tmp_path}")
    assert run.returncode == 0, run.stderr
    result = json.loads((tmp_path / "calibration.json").read_text())
    assert result["inliers"] >= 16 and result["rms_reprojection_px"] < 2.0
    assert result["focal_px"] == pytest.approx(1000, rel=0.02)
    assert result["camera_height_mm"] == pytest.approx(6500, rel=0.02)
    assert cv2.imread(str(tmp_path / "overlay.png")).shape == (720, 1280, 3)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("image={missing}", "video does not exist"),
        ("image={corrupt}", "not a readable video"),
        ("site={missing_site}", "site file does not exist"),
        ("mode=magic", "mode: expected one of detect, guess, auto, got 'magic'"),
    ],
)
def test_calibrate_bad_input_is_one_line_and_exit_1(
    road_and_site: tuple[Path, Path], tmp_path: Path, override: str, message: str
) -> None:
    image, site = road_and_site
    corrupt = tmp_path / "corrupt.avi"
    corrupt.write_bytes(b"RIFF0000AVI garbage" * 10)
    override = override.format(missing=tmp_path / "none.avi", corrupt=corrupt, missing_site=tmp_path / "none.yaml")
    run = _run("vehloc.geometry.pipeline.calibrate_cli", f"site={site}", f"image={image}", override, f"hydra.run.dir={tmp_path / 'out'}")
    assert run.returncode == 1
    assert run.stderr.strip().startswith("vehloc-calibrate: error:") and message in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1


def test_media_errors(tmp_path: Path) -> None:
    with pytest.raises(ImageInputError, match="image does not exist"):
        read_still(tmp_path / "none.png")
    (tmp_path / "bad.png").write_bytes(b"not an image")
    with pytest.raises(ImageInputError, match="not a readable image"):
        read_still(tmp_path / "bad.png")
    (tmp_path / "bad.avi").write_bytes(b"not a video")
    with pytest.raises(MediaError, match="not a readable video"):
        next(iter_frames(tmp_path / "bad.avi"))


def test_median_background_removes_traffic(shared_data: Path) -> None:
    """The median of 60 frames of the real video has no car where frame 800 has one (its mean
    absolute difference to the empty-road median inside that car's box is large)."""
    video = shared_data / "traffic" / "highway_320x240.avi"
    background = median_background(video, 60)
    frame = read_still(video, 800)
    car = (slice(98, 142), slice(192, 248))  # a car annotated by hand in frame 800
    road = (slice(160, 200), slice(180, 240))  # empty road in frame 800
    assert np.abs(frame[car].astype(int) - background[car]).mean() > 25
    assert np.abs(frame[road].astype(int) - background[road]).mean() < 10


def test_scene_cli_writes_video_truth_and_site(tmp_path: Path) -> None:
    run = _run(
        "vehloc.synth.scene_cli", "scene=table2_close_0", f"out={tmp_path}",
        "scene.empty_frames=3", "scene.drive_frames=4", "scene.stopped_frames=2", "scene.cars.0.approach_mm=3000",
    )
    assert run.returncode == 0, run.stderr
    truth = json.loads((tmp_path / "ground_truth.json").read_text())
    frames = list(iter_frames(tmp_path / "video.avi"))
    assert len(frames) == truth["frames"] == 9 and frames[0].shape == (720, 1280, 3)
    (car,) = truth["cars"]
    assert car["target_pose"] == {"x_mm": 194.0, "y_mm": 4060.0, "heading_deg": -2.07} and car["stop_frame"] == 7
    assert car["per_frame_from"] == 3 and len(car["boxes_xyxy_px"]) == 6  # from its entry after the 3 empty frames
    assert car["boxes_xyxy_px"][-1] is not None
    assert (tmp_path / "site.yaml").is_file()
    assert not [path for path in tmp_path.iterdir() if path.name.startswith(".")]  # no temporary file left


def test_scene_cli_names_a_bad_car_setting(tmp_path: Path) -> None:
    run = _run("vehloc.synth.scene_cli", "scene=two_cars", f"out={tmp_path}", "scene.cars.1.model_id=99")
    assert run.returncode == 1
    assert run.stderr.strip() == "vehloc-scene: error: scene.cars[1]: model_id 99 is not a catalog model (1 to 12)"
