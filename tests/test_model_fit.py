"""The model fit against exact ground truth: the predicted model's shape placed on a rendered car's
silhouette from a start 150 mm and 3 deg off."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import FitParams, best_start, fit_model, silhouette
from vehloc.geometry.placement import VehicleBox, axis_difference_deg
from vehloc.synth.body import convex_parts_car_mm
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import CarPose, render_car

CAMERA = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)


def rendered(model_id: int, pose: CarPose) -> tuple[np.ndarray, object]:
    model = model_by_id(model_id)
    background = np.full((720, 1280, 3), 100, np.uint8)
    return render_car(model, model.palette[0][1], pose, CAMERA, background).mask, model


@pytest.mark.parametrize(("model_id", "pose"), [(9, CarPose(404.0, 10530.0, -3.76)), (4, CarPose(-600.0, 4500.0, -60.0))])
def test_the_fitted_shape_finds_the_rendered_pose(model_id: int, pose: CarPose):
    """The model's own shape on its exact silhouette: centre within 0.3 % of the footprint diagonal, heading
    within 0.3 deg (both about 0.05 % and 0.05 deg when measured)."""
    mask, model = rendered(model_id, pose)
    roi = Box.tight(mask).enlarged(0.2, 1280, 720)
    shape = VehicleShape(convex_parts_car_mm(model))
    start = VehicleBox(np.array([pose.x_mm + 150.0, pose.y_mm - 100.0]), pose.heading_deg + 3.0,
                       model.length_mm, model.width_mm)
    fit = fit_model(CAMERA, roi.crop(mask), roi, shape, start, FitParams.from_config())
    diagonal = np.hypot(model.length_mm, model.width_mm)
    assert np.hypot(*(fit.box.centre_mm - [pose.x_mm, pose.y_mm])) <= 0.003 * diagonal
    assert abs(axis_difference_deg(fit.box.heading_deg, pose.heading_deg)) <= 0.3
    assert fit.iou > 0.97 and fit.evaluations > 0


def test_with_the_heading_held_only_the_position_moves():
    """`fit_heading=False` (a moving vehicle, its heading its path's): started 150 mm off at the true heading,
    the heading stays exactly the start's and the centre lands within 0.3 % of the footprint diagonal; started
    3 deg off, it stays 3 deg off."""
    pose = CarPose(404.0, 10530.0, -3.76)
    mask, model = rendered(9, pose)
    roi = Box.tight(mask).enlarged(0.2, 1280, 720)
    shape = VehicleShape(convex_parts_car_mm(model))
    for turn_deg in (0.0, 3.0):
        start = VehicleBox(np.array([pose.x_mm + 150.0, pose.y_mm - 100.0]), pose.heading_deg + turn_deg,
                           model.length_mm, model.width_mm)
        fit = fit_model(CAMERA, roi.crop(mask), roi, shape, start, FitParams.from_config(), fit_heading=False)
        assert abs(axis_difference_deg(fit.box.heading_deg, start.heading_deg)) < 1e-12
        if turn_deg == 0.0:
            assert np.hypot(*(fit.box.centre_mm - [pose.x_mm, pose.y_mm])) <= 0.003 * np.hypot(model.length_mm,
                                                                                              model.width_mm)


def test_the_cuboid_silhouette_is_its_eight_corners_hull():
    """A cuboid's silhouette covers the projections of its corners and nothing far outside them."""
    box = VehicleBox(np.array([0.0, 9000.0]), 20.0, 4500.0, 1800.0)
    shape = VehicleShape.cuboid(4500.0, 1800.0, 1500.0)
    corners_px = CAMERA.project(box.cuboid_mm(1500.0))
    roi = Box(0, 0, 1280, 720)
    mask = silhouette(CAMERA, shape, box, roi, 1)
    x0, y0 = np.floor(corners_px.min(axis=0)).astype(int)
    x1, y1 = np.ceil(corners_px.max(axis=0)).astype(int)
    tight = Box.tight(mask)
    assert tight is not None and abs(tight.x0 - x0) <= 1 and abs(tight.y0 - y0) <= 1 and abs(tight.x1 - x1) <= 1 and abs(tight.y1 - y1) <= 1


def test_the_coarse_search_picks_the_start_nearest_the_car():
    """Starts every 500 mm along the road from 2 m before to 2 m beyond a rendered Spirior: the one at its true
    centre overlaps its silhouette most and is the one picked."""
    pose = CarPose(404.0, 10530.0, -3.76)
    mask, model = rendered(9, pose)
    roi = Box.tight(mask).enlarged(0.2, 1280, 720)
    shape = VehicleShape(convex_parts_car_mm(model))
    candidates = [VehicleBox(np.array([pose.x_mm, pose.y_mm + offset]), pose.heading_deg, model.length_mm,
                             model.width_mm) for offset in np.arange(-2000.0, 2001.0, 500.0)]
    picked = best_start(CAMERA, roi.crop(mask).astype(np.float32), roi, shape, candidates, 2)
    np.testing.assert_array_equal(picked.centre_mm, [pose.x_mm, pose.y_mm])
