"""1-sigma uncertainty parts against values worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.uncertainty import (
    Uncertainty,
    calibration_part,
    dimension_spread_mm,
    fitted_spread,
    paper_dimension_part,
    road_mm_per_px,
)


def test_dimension_spread_over_the_top_k():
    """Two models at 0.45 each (renormalised to 0.5) 1000 mm apart in length: sigma_L = 500 mm; the third,
    beyond k = 2, does not count. The plate's placement doubts half of sigma_L, two wheels' half of sigma_W, one
    wheel's both (its Q half a wheelbase along the side, the wheelbase's doubt taken as the length's)."""
    dims = np.array([[4000.0, 1800.0, 1400.0], [5000.0, 1800.0, 1600.0], [9000.0, 2500.0, 3000.0]])
    spread = dimension_spread_mm(np.array([0.45, 0.45, 0.10]), dims, top_k=2)
    np.testing.assert_allclose(spread, [500.0, 0.0, 100.0])
    assert paper_dimension_part("plate", spread) == (250.0, 0.0)
    assert paper_dimension_part("wheels", spread) == (0.0, 0.0)
    assert paper_dimension_part("wheel", spread) == (250.0, 0.0)  # one wheel: half the length's doubt along the side


def test_millimetres_per_pixel_of_a_camera_looking_down():
    """Looking straight down from 10 m with a 1000 px focal length, a pixel spans 10 mm on the road (1e-6)."""
    camera = PinholeCamera.look_at([0.0, 0.0, 10000.0], [0.0, 0.0, 0.0], 1000.0, 640, 480)
    assert road_mm_per_px(camera.road_to_image(), np.array([300.0, -200.0])) == pytest.approx(10.0, rel=1e-6)


def test_calibration_share_and_quadrature():
    position_mm, heading_deg = calibration_part(0.8, 10.0, 2000.0)
    assert position_mm == pytest.approx(8.0) and heading_deg == pytest.approx(np.degrees(np.sqrt(2) * 8.0 / 2000.0))
    combined = Uncertainty.combined((30.0, 0.0), (40.0, 0.3))
    assert (combined.position_mm, combined.heading_deg) == (pytest.approx(50.0), pytest.approx(0.3))
    with_path = Uncertainty.combined((30.0, 0.0), (40.0, 0.3), (0.0, 0.4))
    assert (with_path.position_mm, with_path.heading_deg) == (pytest.approx(50.0), pytest.approx(0.5))


def test_spread_of_fitted_poses():
    """Two equally likely fits 200 mm apart and 2 deg apart: 100 mm and 1 deg about their mean."""
    boxes = [VehicleBox(np.array([0.0, 0.0]), 10.0, 4500.0, 1800.0), VehicleBox(np.array([200.0, 0.0]), 12.0, 4500.0, 1800.0)]
    position, heading = fitted_spread(boxes, np.array([0.3, 0.3]))
    assert position == pytest.approx(100.0) and heading == pytest.approx(1.0)
