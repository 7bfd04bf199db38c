"""The model fit's start from a stopped vehicle's silhouette when no key points are found
(`pipeline.fit_from_silhouette`): the lowest vehicle pixel of each column, the principal road direction of
those points, and the headings the fit starts from, against exact ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.pipeline.settings import PipelineParams
from vehloc.geometry.placement import axis_difference_deg
from vehloc.geometry.silhouette_start import lower_outline_px, principal_road_heading_deg, silhouette_start_headings_deg
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import CarPose, render_car
from vehloc.synth.road import RoadLayout, render_road

CAMERA = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)


def test_the_lower_outline_is_the_bottom_of_each_columns_lowest_pixel():
    mask = np.zeros((10, 6), bool)
    mask[2:5, 1] = True
    mask[3:8, 3] = True
    mask[0, 4] = True
    np.testing.assert_array_equal(lower_outline_px(mask, np.array([100.0, 50.0])),
                                  [[101.5, 55.0], [103.5, 58.0], [104.5, 51.0]])


@pytest.mark.parametrize("heading_deg", [0.0, 30.0, 90.0, 135.0, 179.0])
def test_the_principal_direction_of_points_on_a_line_is_the_lines(heading_deg: float):
    """Points along a line with a small perpendicular scatter: the axis to 1e-9 deg without it, 0.5 deg with it."""
    along = np.linspace(-2000.0, 2000.0, 41)
    direction = np.array([np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))])
    points = np.array([500.0, 9000.0]) + along[:, None] * direction
    assert axis_difference_deg(principal_road_heading_deg(points), heading_deg) == pytest.approx(0.0, abs=1e-9)
    scatter = np.random.default_rng(0).normal(0.0, 30.0, len(along))[:, None] * np.array([-direction[1], direction[0]])
    assert abs(axis_difference_deg(principal_road_heading_deg(points + scatter), heading_deg)) < 0.5


def test_too_few_or_unseen_points_give_no_direction():
    assert principal_road_heading_deg(np.array([[0.0, 1.0], [2.0, 3.0]])) is None
    assert principal_road_heading_deg(np.full((5, 2), np.nan)) is None
    assert principal_road_heading_deg(np.ones((5, 2))) is None
    assert silhouette_start_headings_deg(np.zeros((20, 20), bool), np.zeros(2), CAMERA.road_to_image()) == ()


@pytest.mark.parametrize(("heading_deg", "tolerance_deg"), [(0.0, 5.0), (20.0, 8.0)])
def test_a_car_seen_side_on_starts_along_its_length(heading_deg: float, tolerance_deg: float):
    """A rendered Spirior across the road, 10 m up it: the silhouette's lower outline runs along its near side,
    so the first start heading is the car's axis (within the stated tolerance: the outline's front and rear
    ends curve away) and the second its perpendicular."""
    background = render_road(CAMERA, RoadLayout(lane_count=3, lane_width_mm=3500.0), np.random.default_rng(0))
    render = render_car(model_by_id(9), (180, 180, 180), CarPose(0.0, 10000.0, heading_deg), CAMERA, background,
                        shadow_strength=0.0)
    box = render.box
    mask = render.mask[box.y0:box.y1, box.x0:box.x1]
    first, second = silhouette_start_headings_deg(mask, np.array([box.x0, box.y0], float), CAMERA.road_to_image())
    assert abs(axis_difference_deg(first, heading_deg)) < tolerance_deg
    assert abs(axis_difference_deg(second, heading_deg + 90.0)) == pytest.approx(abs(axis_difference_deg(first, heading_deg)),
                                                                                 abs=1e-9)


def test_the_fit_from_the_silhouette_is_on_by_default():
    assert PipelineParams.from_config().fit_from_silhouette is True
    assert PipelineParams.from_config(fit_from_silhouette=False).fit_from_silhouette is False
