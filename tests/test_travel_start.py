"""The model fit's start without key points (`pipeline.fit_from_travel`): the footprint's nearest point is the
road point under the box's bottom, the centre lies half the footprint's extent beyond it along the line of
sight. Exact to 1e-9 mm and deg."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.localize import PipelineParams, travel_start_box

LENGTH_MM, WIDTH_MM = 4800.0, 1850.0


@pytest.mark.parametrize(("heading_deg", "depth_mm"), [(90.0, LENGTH_MM / 2), (-90.0, LENGTH_MM / 2),
                                                       (0.0, WIDTH_MM / 2), (180.0, WIDTH_MM / 2)])
def test_a_car_straight_ahead_starts_half_its_extent_beyond_the_nearest_point(heading_deg: float, depth_mm: float):
    box = travel_start_box(np.array([0.0, 20000.0]), np.array([0.0, -5000.0]), LENGTH_MM, WIDTH_MM, heading_deg)
    np.testing.assert_allclose(box.centre_mm, [0.0, 20000.0 + depth_mm], atol=1e-9)
    assert box.heading_deg == heading_deg and (box.length_mm, box.width_mm) == (LENGTH_MM, WIDTH_MM)


def test_an_oblique_line_of_sight_weighs_length_and_width_by_its_angle():
    nearest, foot = np.array([3000.0, 4000.0]), np.zeros(2)  # sight (0.6, 0.8)
    box = travel_start_box(nearest, foot, LENGTH_MM, WIDTH_MM, 90.0)  # forward (0, 1), left (-1, 0)
    depth_mm = LENGTH_MM / 2 * 0.8 + WIDTH_MM / 2 * 0.6
    np.testing.assert_allclose(box.centre_mm, nearest + depth_mm * np.array([0.6, 0.8]), atol=1e-9)


def test_the_fit_without_key_points_is_off_unless_asked():
    assert PipelineParams.from_config().fit_from_travel is False
    assert PipelineParams.from_config(fit_from_travel=True).fit_from_travel is True
