"""Traffic scenes: configs, exact ground truth, and the site file made for them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scene_configs import TABLE2_SCENES, scene_spec

from vehloc.geometry.projective import ProjectiveTransform
from vehloc.synth.scene import SceneSpec, car_pose_at, render_frames, write_scene
from vehloc.synth.scene_site import scene_site

PAPER_TABLE2_REAL_POSES = {
    "table2_middle_0": (404, 10530, -3.76), "table2_middle_30": (456, 9706, 16.95),
    "table2_middle_minus30": (76, 11087, -32.71), "table2_close_0": (194, 4060, -2.07),
    "table2_close_30": (548, 4147, 23.92), "table2_close_minus30": (-181, 3958, -26.30),
}


@pytest.mark.parametrize("name", TABLE2_SCENES)
def test_table2_configs_compose_with_the_paper_poses(name: str) -> None:
    spec = scene_spec(name)
    assert (spec.target_x_mm, spec.target_y_mm, spec.target_heading_deg) == PAPER_TABLE2_REAL_POSES[name]
    assert spec.empty_frames >= 150 and spec.model_id == 9
    assert (spec.camera.width_px, spec.camera.height_px) == (1280, 720)


def test_unknown_scene_setting_is_an_error() -> None:
    with pytest.raises(ValueError, match="unknown scene setting\\(s\\): speed"):
        SceneSpec.from_dict({"speed": 3})


def test_car_decelerates_to_the_target_pose() -> None:
    spec = SceneSpec(target_x_mm=500, target_y_mm=9000, target_heading_deg=30, empty_frames=5, drive_frames=10)
    assert car_pose_at(spec, 4) is None
    start = car_pose_at(spec, 5)
    assert np.hypot(start.x_mm - 500, start.y_mm - 9000) == pytest.approx(spec.approach_mm)
    assert np.degrees(np.arctan2(9000 - start.y_mm, 500 - start.x_mm)) == pytest.approx(30)
    steps = [np.hypot(car_pose_at(spec, f + 1).x_mm - car_pose_at(spec, f).x_mm,
                      car_pose_at(spec, f + 1).y_mm - car_pose_at(spec, f).y_mm) for f in range(5, 15)]
    assert all(a > b for a, b in zip(steps, steps[1:]))
    assert car_pose_at(spec, 15) == car_pose_at(spec, 40) == spec.target_pose


def test_ground_truth_is_exact(tmp_path: Path) -> None:
    spec = scene_spec("table2_close_30", empty_frames=2, drive_frames=3, stopped_frames=2, approach_mm=3000.0)
    video, truth_path = write_scene(spec, tmp_path)
    truth = json.loads(truth_path.read_text())
    camera = spec.camera.camera()
    assert video.stat().st_size > 0 and truth["frames"] == 7 == len(truth["boxes_xyxy_px"])
    assert truth["boxes_xyxy_px"][:2] == [None, None] and truth["boxes_xyxy_px"][-1] is not None
    homography = ProjectiveTransform.road_to_image(np.array(truth["homography_world_mm_to_image_px"]), 1280, 720)
    car = truth["car"]
    footprint = np.array(car["footprint_corners_mm"])
    # footprint: centred on the pose, L x W, front edge facing the heading (tolerance 1e-6 mm)
    np.testing.assert_allclose(footprint.mean(axis=0), [548, 4147], atol=1e-6)
    assert np.linalg.norm(footprint[0] - footprint[3]) == pytest.approx(car["length_mm"], abs=1e-6)
    assert np.linalg.norm(footprint[0] - footprint[1]) == pytest.approx(car["width_mm"], abs=1e-6)
    front_mid = (footprint[0] + footprint[1]) / 2 - [548, 4147]
    assert np.degrees(np.arctan2(front_mid[1], front_mid[0])) == pytest.approx(23.92, abs=1e-9)
    tyres = np.array(car["tyre_contacts_mm"])
    assert np.linalg.norm(tyres[0] - tyres[2]) == pytest.approx(car["wheelbase_mm"], abs=1e-6)
    # image coordinates are the world ones through the road homography (tolerance 1e-6 px)
    np.testing.assert_allclose(homography(tyres), car["tyre_contacts_px"], atol=1e-6)
    marker = next(m for m in truth["markers"] if m["has_corners"] and None not in m["corners_px"])
    np.testing.assert_allclose(homography(np.array(marker["corners_mm"])), marker["corners_px"], atol=1e-6)
    np.testing.assert_allclose(truth["camera"]["centre_mm"], camera.centre_mm, atol=1e-9)


def test_stopped_frames_repeat_the_rendered_car_with_fresh_noise() -> None:
    spec = scene_spec("table2_middle_0", empty_frames=1, drive_frames=2, stopped_frames=2, approach_mm=2000.0)
    frames = list(render_frames(spec))
    (last_a, box_a), (last_b, box_b) = frames[-2], frames[-1]
    assert box_a == box_b is not None
    difference = last_a.astype(float) - last_b
    assert 1.0 < difference.std() < 4.0  # two frames of sensor noise (sigma 2 each), same content


def test_scene_site_guess_is_close_to_the_truth() -> None:
    spec = scene_spec("table2_middle_30")
    site = scene_site(spec, click_noise_px=2.0, seed=0)
    truth = spec.camera.camera().road_to_image()
    world = np.array([w for w, _ in site.guess_points])
    error_px = site.initial_transform()(world) - truth(world)
    assert np.all(np.linalg.norm(error_px, axis=1) < 10.0)
    assert len(site.markers) == sum(m.has_corners for m in spec.layout.markers())
