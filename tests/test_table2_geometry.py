"""Calibration and vehicle ROI on the six rendered Table 2 scenes, against their exact ground truth."""

from __future__ import annotations

import numpy as np
import pytest
from scene_configs import SIDE_ON_SCENES, scene_spec

from vehloc.geometry.calibration import calibrate
from vehloc.geometry.markers import detect_markers
from vehloc.geometry.pipeline.tracker import StoppedVehicleTracker
from vehloc.geometry.roi import VehicleRoiExtractor
from vehloc.synth.road import render_road
from vehloc.synth.scene import render_frames
from vehloc.synth.scene_site import scene_site


@pytest.mark.parametrize("name", SIDE_ON_SCENES)
def test_calibration_on_table2_scene(name: str) -> None:
    """Tolerances (issue): reprojection RMS <= 1 px over the surveyed corners in view; image points
    mapped back to the road within 1 % of their distance from the camera."""
    spec = scene_spec(name)
    camera = spec.camera.camera()
    empty_road = render_road(camera, spec.layout, np.random.default_rng(spec.seed))
    site = scene_site(spec, click_noise_px=2.0, seed=spec.seed)
    calibration = calibrate(detect_markers(empty_road), site, image_bgr=empty_road)
    truth = camera.road_to_image()

    world, _ = site.world_corners_mm()
    pixels = truth(world)
    in_view = (pixels[:, 0] >= 0) & (pixels[:, 0] < 1280) & (pixels[:, 1] >= 0) & (pixels[:, 1] < 720)
    in_view &= camera.to_camera(np.column_stack([world, np.zeros(len(world))]))[:, 2] > 0
    error_px = calibration.road_to_image(world[in_view]) - pixels[in_view]
    assert np.sqrt(np.mean(np.sum(error_px**2, axis=1))) <= 1.0

    road_px = truth(np.array([[x, y] for x in (-4000, 0, 4000) for y in (2000, 6000, 12000, 25000)]))
    true_mm = camera.image_to_road(road_px)
    distance_mm = np.linalg.norm(np.column_stack([true_mm, np.zeros(len(true_mm))]) - camera.centre_mm, axis=1)
    assert np.all(np.linalg.norm(calibration.image_to_road(road_px) - true_mm, axis=1) <= 0.01 * distance_mm)


@pytest.mark.slow
@pytest.mark.parametrize("name", SIDE_ON_SCENES)
def test_roi_of_the_stopped_car(name: str) -> None:
    """The stop signal fires within 20 frames of the stop, once, and the ROI box then has IoU >= 0.85
    with the true box of the rendered car (the issue's tolerance)."""
    spec = scene_spec(name, drive_frames=40, stopped_frames=25)
    extractor, tracker = VehicleRoiExtractor(), StoppedVehicleTracker(vote_frames=1)
    stops = []
    for frame_index, (frame, (true_box,)) in enumerate(render_frames(spec)):
        for track in tracker.update(extractor.apply(frame), frame_index).stopped:
            stops.append((frame_index, track.box.iou(true_box)))
    assert len(stops) == 1, stops
    frame_index, iou = stops[0]
    stop_frame = spec.stop_frame(spec.cars[0])
    assert stop_frame <= frame_index <= stop_frame + 20
    assert iou >= 0.85
