"""The one projective transform: apply, inverse, compose, lines, and points at or beyond the horizon
reported instead of divided by zero. Exact ground truth from a pinhole camera; tolerances stated."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.projective import HorizonError, ProjectiveTransform

CAMERA = PinholeCamera.look_at([1000.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720, roll_deg=2.0)


def road_points(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-5000, 5000, n), rng.uniform(0, 40000, n)])


def test_forward_and_inverse_agree_with_the_camera():
    """Road -> image equals the pinhole projection, image -> road recovers the road point (1e-6 px / mm)."""
    road_mm = road_points(100)
    transform = CAMERA.road_to_image()
    pixels = transform(road_mm)
    np.testing.assert_allclose(pixels, CAMERA.project(np.column_stack([road_mm, np.zeros(100)])), atol=1e-6)
    np.testing.assert_allclose(transform.inverse(pixels), road_mm, atol=1e-6)


def test_the_jacobian_is_the_derivative_of_the_mapping():
    """Road to image, image to road, and the matrix times -3: central differences of 1e-3 agree to 1e-6."""
    road_mm = road_points(50, seed=1)
    forward = CAMERA.road_to_image()
    cases = ((forward, road_mm), (forward.inverse, forward(road_mm)),
             (ProjectiveTransform(-3.0 * forward.matrix, -forward.front_sign), road_mm))
    step = 1e-3
    for transform, source in cases:
        numeric = np.stack([(transform(source + offset) - transform(source - offset)) / (2 * step)
                            for offset in (np.array([step, 0.0]), np.array([0.0, step]))], axis=2)
        np.testing.assert_allclose(transform.jacobian(source), numeric, atol=1e-6)


def test_scaling_by_a_negative_factor_keeps_the_visible_side():
    """The same homography times -3: the same images, the same points reported beyond the horizon."""
    transform = CAMERA.road_to_image()
    flipped = ProjectiveTransform.road_to_image(-3.0 * transform.matrix, 1280, 720)
    assert flipped.front_sign == -1.0
    points = np.vstack([road_points(20), [[0.0, -30000.0], [500.0, -20000.0]]])  # two behind the image plane
    np.testing.assert_allclose(flipped(points), transform(points), atol=1e-9, equal_nan=True)
    assert flipped.is_visible(points).tolist() == [True] * 20 + [False, False]


def test_points_behind_the_camera_and_above_the_horizon_are_reported():
    transform = CAMERA.road_to_image()
    behind = np.array([[0.0, -30000.0], [0.0, -50000.0]])  # behind the camera at Y = -6000, 6.5 m up
    mapped = transform.map(behind)
    assert not mapped.visible.any() and np.isnan(mapped.points).all()
    with pytest.raises(HorizonError, match="2 of 2 road point"):
        transform.map_visible(behind, "road point")
    sky_px = np.array([[640.0, -200.0], [10.0, -500.0]])  # the horizon of this camera is at y = -75 px
    assert not transform.inverse.is_visible(sky_px).any()


def test_a_point_exactly_on_the_horizon_is_not_divided_by_zero():
    """The road line imaged at infinity: w is exactly 0 for a transform built to have it so."""
    matrix = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 1.0, 1.0]])  # w = y + 1
    transform = ProjectiveTransform(matrix)
    with np.errstate(all="raise"):
        mapped = transform.map(np.array([[5.0, -1.0], [5.0, 1.0], [5.0, -2.0]]))
    assert mapped.visible.tolist() == [False, True, False]
    np.testing.assert_allclose(mapped.points[1], [2.5, 0.5])


def test_composition_and_line_mapping():
    """(A @ B)(p) == A(B(p)); a road line maps onto the line through the images of its points (1e-9)."""
    road_to_image = CAMERA.road_to_image()
    shift_mm = ProjectiveTransform(np.array([[1.0, 0.0, 250.0], [0.0, 1.0, -400.0], [0.0, 0.0, 1.0]]))
    points = road_points(30, seed=1)
    np.testing.assert_allclose((road_to_image @ shift_mm)(points), road_to_image(shift_mm(points)), atol=1e-9)
    identity = road_to_image @ road_to_image.inverse
    pixels = road_to_image(points)
    np.testing.assert_allclose(identity(pixels), pixels, atol=1e-6)
    a, b = np.array([-1000.0, 5000.0]), np.array([2000.0, 30000.0])
    image_line = road_to_image.map_lines(np.cross([*a, 1.0], [*b, 1.0]))[0]
    on_line = road_to_image(a[None] + np.linspace(0, 1, 7)[:, None] * (b - a))
    distances = (np.column_stack([on_line, np.ones(7)]) @ image_line) / np.hypot(*image_line[:2])
    np.testing.assert_allclose(distances, 0.0, atol=1e-9)


def test_bad_matrices_are_refused():
    with pytest.raises(ValueError, match="finite 3x3"):
        ProjectiveTransform(np.eye(2))
    with pytest.raises(ValueError, match="invertible"):
        ProjectiveTransform(np.ones((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        ProjectiveTransform(np.full((3, 3), np.nan))
