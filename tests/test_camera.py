"""PinholeCamera: projection, pose conventions and the road-plane homography."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.geometry.camera import PinholeCamera


def _traffic_camera() -> PinholeCamera:
    """An elevated camera beside the road looking down the road, slightly rolled."""
    return PinholeCamera.look_at(
        position_mm=[-4000.0, -12000.0, 7000.0],
        target_mm=[500.0, 15000.0, 0.0],
        focal_px=800.0,
        width_px=640,
        height_px=480,
        roll_deg=3.0,
    )


def test_road_points_round_trip_through_the_image() -> None:
    camera = _traffic_camera()
    rng = np.random.default_rng(0)
    road_mm = np.column_stack([rng.uniform(-6000, 6000, 200), rng.uniform(0, 40000, 200)])
    pixels = camera.project(np.column_stack([road_mm, np.zeros(200)]))
    back_mm = camera.image_to_road(pixels)
    np.testing.assert_allclose(back_mm, road_mm, atol=1e-6, rtol=0)


def test_look_at_target_projects_to_principal_point() -> None:
    camera = _traffic_camera()
    pixel = camera.project(np.array([[500.0, 15000.0, 0.0]]))[0]
    np.testing.assert_allclose(pixel, [319.5, 239.5], atol=1e-9)
    shifted = PinholeCamera.look_at(
        [0, -5000, 1500], [0, 0, 700], 500.0, 320, 240, principal_px=(100.0, 50.0)
    )
    np.testing.assert_allclose(shifted.project([[0, 0, 700]])[0], [100.0, 50.0], atol=1e-9)


def test_homography_agrees_with_projection_on_the_road() -> None:
    camera = _traffic_camera()
    rng = np.random.default_rng(1)
    road_mm = np.column_stack([rng.uniform(-8000, 8000, 50), rng.uniform(0, 30000, 50)])
    mapped = camera.road_to_image()(road_mm)
    np.testing.assert_allclose(mapped, camera.project(np.column_stack([road_mm, np.zeros(50)])), atol=1e-9)


def test_camera_looking_straight_down_gives_the_analytic_pixel() -> None:
    height_mm, focal_px = 10000.0, 1000.0
    camera = PinholeCamera.look_at([0.0, 0.0, height_mm], [0.0, 0.0, 0.0], focal_px, 640, 480)
    # Image up is +Y, so +X is image right and +Y is image up; 1 m off-axis at 10 m is f/10 px.
    pixels = camera.project(np.array([[1000.0, 0.0, 0.0], [0.0, 2000.0, 0.0], [0.0, 0.0, 0.0]]))
    np.testing.assert_allclose(pixels[0], [319.5 + 100.0, 239.5], atol=1e-9)
    np.testing.assert_allclose(pixels[1], [319.5, 239.5 - 200.0], atol=1e-9)
    np.testing.assert_allclose(pixels[2], [319.5, 239.5], atol=1e-9)
    np.testing.assert_allclose(camera.centre_mm, [0.0, 0.0, height_mm], atol=1e-9)


def test_from_pose_angle_conventions() -> None:
    position = np.array([100.0, -200.0, 1500.0])
    level = PinholeCamera.from_pose(position, 0.0, 0.0, 0.0, 500.0, 320, 240)
    np.testing.assert_allclose(level.R[2], [0.0, 1.0, 0.0], atol=1e-12)  # yaw 0 looks along +Y
    np.testing.assert_allclose(level.R[0], [1.0, 0.0, 0.0], atol=1e-12)  # image right is +X
    turned = PinholeCamera.from_pose(position, 90.0, 30.0, 0.0, 500.0, 320, 240)
    np.testing.assert_allclose(turned.R[2], [np.cos(np.radians(30)), 0.0, -0.5], atol=1e-12)
    np.testing.assert_allclose(turned.centre_mm, position, atol=1e-9)
    # A point straight ahead and below is below the image centre for a level camera.
    below = level.project(position + np.array([[0.0, 5000.0, -1000.0]]))[0]
    assert below[1] > 119.5 + 50
    # Positive roll turns the horizon counter-clockwise: a point to the right moves up.
    rolled = PinholeCamera.from_pose(position, 0.0, 0.0, 10.0, 500.0, 320, 240)
    right = rolled.project(position + np.array([[1000.0, 5000.0, 0.0]]))[0]
    assert right[0] > 159.5 and right[1] < 119.5 - 10


def test_look_at_matches_from_pose() -> None:
    position = np.array([3000.0, -9000.0, 6000.0])
    a = PinholeCamera.look_at(position, position + [1.0, 1.0, -np.sqrt(2.0)], 700.0, 320, 240, roll_deg=5.0)
    b = PinholeCamera.from_pose(position, 45.0, 45.0, 5.0, 700.0, 320, 240)
    np.testing.assert_allclose(a.R, b.R, atol=1e-12)
    np.testing.assert_allclose(a.t, b.t, atol=1e-9)
    np.testing.assert_allclose(a.R @ a.R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(a.R) == pytest.approx(1.0)


def test_points_behind_the_camera_project_to_nan() -> None:
    camera = PinholeCamera.from_pose([0, 0, 1000], 0.0, 0.0, 0.0, 500.0, 320, 240)
    pixels = camera.project(np.array([[0.0, -100.0, 1000.0], [0.0, 100.0, 1000.0]]))
    assert np.isnan(pixels[0]).all() and np.isfinite(pixels[1]).all()


def test_bad_shapes_are_rejected() -> None:
    with pytest.raises(ValueError, match="shape"):
        PinholeCamera(K=np.eye(2), R=np.eye(3), t=np.zeros(3), width_px=10, height_px=10)
    camera = PinholeCamera.from_pose([0, 0, 1000], 0.0, 0.0, 0.0, 500.0, 320, 240)
    with pytest.raises(ValueError, match="points"):
        camera.project(np.zeros((4, 2)))
