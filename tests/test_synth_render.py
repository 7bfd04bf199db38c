"""The car renderer: coverage and box, ground-truth points, pose convention, clipping."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vehloc.data.boxes import Box
from vehloc.geometry.camera import NEAR_PLANE_MM, PinholeCamera, clip_to_near_plane
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import (
    CarPose,
    Lighting,
    _projected_faces,
    _rasterise,
    fill_world_polygon,
    footprint_car_mm,
    render_car,
)

WHITE_RGB = (235, 235, 235)


def _camera_around(
    pose: CarPose, azimuth_deg: float, elevation_deg: float, distance_mm: float, focal_px: float = 260.0
) -> PinholeCamera:
    """A camera at ``azimuth_deg`` around the car from its front, looking at its middle."""
    direction = np.radians(pose.heading_deg + azimuth_deg)
    elevation = np.radians(elevation_deg)
    target = np.array([pose.x_mm, pose.y_mm, 700.0])
    position = target + distance_mm * np.array(
        [np.cos(elevation) * np.cos(direction), np.cos(elevation) * np.sin(direction), np.sin(elevation)]
    )
    return PinholeCamera.look_at(position, target, focal_px, 320, 240)


def _uniform(value: int) -> np.ndarray:
    return np.full((240, 320, 3), value, np.uint8)


def test_box_is_tight_around_the_pixels_the_car_covers() -> None:
    model = model_by_id(4)
    pose = CarPose(1200.0, -800.0, 30.0)
    camera = _camera_around(pose, 55.0, 20.0, 11000.0)
    on_black = render_car(model, WHITE_RGB, pose, camera, _uniform(0), shadow_strength=0.0)
    on_white = render_car(model, WHITE_RGB, pose, camera, _uniform(255), shadow_strength=0.0)
    # Over black and white backgrounds a pixel differs by 255 * (1 - coverage).
    difference = on_white.image_bgr.astype(float) - on_black.image_bgr.astype(float)
    coverage = 1.0 - difference.mean(axis=2) / 255.0
    np.testing.assert_allclose(coverage, on_black.coverage, atol=2.5 / 255)
    measured = Box.tight(coverage >= 0.5)
    assert measured is not None and on_black.box is not None
    np.testing.assert_allclose(measured.as_tuple(), on_black.box.as_tuple(), atol=1)
    x0, y0, x1, y1 = on_black.box.as_tuple()
    assert 0 < x0 < x1 < 320 and 0 < y0 < y1 < 240
    assert on_black.box.width_px > 80 and on_black.box.height_px > 40
    assert on_black.mask.sum() == (on_black.coverage >= 0.5).sum() > 2000


def test_ground_truth_points_are_projections_and_touch_the_rendered_tyres() -> None:
    model = model_by_id(1)
    pose = CarPose(0.0, 0.0, 0.0)
    camera = _camera_around(pose, 90.0, 10.0, 12000.0)  # the car's left side
    render = render_car(model, WHITE_RGB, pose, camera, _uniform(128))
    hl, hw = model.length_mm / 2, model.width_mm / 2
    np.testing.assert_allclose(
        render.footprint_corners_mm[:, :2], [[hl, hw], [hl, -hw], [-hl, -hw], [-hl, hw]]
    )
    np.testing.assert_allclose(render.footprint_corners_px, camera.project(render.footprint_corners_mm))
    np.testing.assert_allclose(render.tyre_contacts_px, camera.project(render.tyre_contacts_mm))
    np.testing.assert_allclose(
        render.tyre_contacts_mm[0, 0] - render.tyre_contacts_mm[2, 0], model.wheelbase_mm
    )
    np.testing.assert_allclose(
        render.tyre_contacts_mm[0, 1] - render.tyre_contacts_mm[1, 1], model.track_front_mm, atol=1e-9
    )
    # The near (left) tyres' contact points lie on the bottom edge of the car's rendered pixels.
    for x_px, y_px in render.tyre_contacts_px[[0, 2]]:
        column = render.mask[:, int(round(x_px))]
        assert abs(np.flatnonzero(column)[-1] - y_px) <= 2.0


def test_heading_convention_turns_the_car_counter_clockwise() -> None:
    model = model_by_id(1)
    top_down = PinholeCamera.look_at([0.0, 0.0, 20000.0], [0.0, 0.0, 0.0], 300.0, 320, 240)
    along_x = render_car(model, WHITE_RGB, CarPose(0.0, 0.0, 0.0), top_down, _uniform(128)).box
    along_y = render_car(model, WHITE_RGB, CarPose(0.0, 0.0, 90.0), top_down, _uniform(128)).box
    assert along_x is not None and along_y is not None
    assert along_x.width_px > 2 * along_x.height_px  # long across the image (world X)
    assert along_y.height_px > 2 * along_y.width_px  # long up the image (world Y)
    pose = CarPose(0.0, 0.0, 90.0)
    np.testing.assert_allclose(pose.car_to_world([[1000.0, 0.0, 0.0]]), [[0.0, 1000.0, 0.0]], atol=1e-9)


def _red_pixels(image_bgr: np.ndarray) -> int:
    b, g, r = (image_bgr[:, :, i].astype(int) for i in range(3))
    return int(((r > 100) & (r > 2 * g) & (r > 2 * b)).sum())


@pytest.mark.parametrize("heading_deg", [0.0, 135.0])
def test_tail_lights_show_from_behind_and_not_from_the_front(heading_deg: float) -> None:
    model = model_by_id(9)
    pose = CarPose(500.0, 2000.0, heading_deg)
    front = render_car(model, WHITE_RGB, pose, _camera_around(pose, 0.0, 10.0, 9000.0, 400.0), _uniform(128))
    rear = render_car(model, WHITE_RGB, pose, _camera_around(pose, 180.0, 10.0, 9000.0, 400.0), _uniform(128))
    assert _red_pixels(front.image_bgr) == 0
    assert _red_pixels(rear.image_bgr) > 30


def test_rendering_is_deterministic_and_checks_its_inputs() -> None:
    model = model_by_id(11)
    pose = CarPose(0.0, 0.0, 10.0)
    camera = _camera_around(pose, 200.0, 25.0, 8000.0)
    a = render_car(model, (190, 25, 30), pose, camera, _uniform(90))
    b = render_car(model, (190, 25, 30), pose, camera, _uniform(90))
    assert np.array_equal(a.image_bgr, b.image_bgr)
    with pytest.raises(ValueError, match="background shape"):
        render_car(model, (190, 25, 30), pose, camera, np.zeros((10, 10, 3), np.uint8))
    inside = PinholeCamera.look_at([0.0, 0.0, 700.0], [0.0, 5000.0, 700.0], 260.0, 320, 240)
    with pytest.raises(ValueError, match="in front of the camera"):
        render_car(model, (190, 25, 30), pose, inside, _uniform(90))


def test_near_plane_clipping_and_road_polygons() -> None:
    square = np.array([[0.0, 0.0, -500.0], [100.0, 0.0, -500.0], [100.0, 0.0, 1000.0], [0.0, 0.0, 1000.0]])
    clipped = clip_to_near_plane(square)
    assert len(clipped) == 4 and clipped[:, 2].min() == pytest.approx(NEAR_PLANE_MM)
    assert len(clip_to_near_plane(square * np.array([1.0, 1.0, -1.0]) - [0, 0, 2000.0])) == 0

    camera = PinholeCamera.look_at([0.0, -6000.0, 1500.0], [0.0, 0.0, 0.0], 300.0, 320, 240)
    image = np.zeros((240, 320), np.float32)
    # A road strip running from behind the camera far ahead: clipped, then filled.
    road = np.array(
        [[-1750.0, -20000.0, 0.0], [1750.0, -20000.0, 0.0], [1750.0, 80000.0, 0.0], [-1750.0, 80000.0, 0.0]]
    )
    fill_world_polygon(image, camera, road, (1.0,))
    centre = camera.project([[0.0, 0.0, 0.0]])[0]
    assert image[int(round(centre[1])), int(round(centre[0]))] == pytest.approx(1.0)
    outside = camera.project([[2500.0, 0.0, 0.0]])[0]
    assert image[int(round(outside[1])), int(round(outside[0]))] == 0.0
    assert image[0].max() == 0.0  # nothing above the horizon


def test_plate_truth_lies_on_the_rendered_plate() -> None:
    """Seen from 20 deg off the front: the front plate faces the camera, the rear one does not, and the
    projected front plate is the light plate of the render: within the car, with bright pixels (plate)
    where the same quad one plate-height lower has none."""
    model = model_by_id(9)
    pose = CarPose(0.0, 0.0, 0.0)
    camera = _camera_around(pose, 20.0, 15.0, 7000.0, focal_px=500.0)
    render = render_car(model, (60, 60, 160), pose, camera, _uniform(90), shadow_strength=0.0)
    front, rear = render.plates["front"], render.plates["rear"]
    assert front.faces_camera and not rear.faces_camera
    np.testing.assert_allclose(front.corners_px, camera.project(front.corners_mm), atol=1e-9)
    grey = render.image_bgr.mean(axis=2)

    def quad(corners_px: np.ndarray) -> np.ndarray:
        inside = np.zeros(render.mask.shape, np.uint8)
        cv2.fillConvexPoly(inside, np.round(corners_px).astype(np.int32), 1)
        return inside > 0

    plate, below = quad(front.corners_px), quad(camera.project(front.corners_mm - [0.0, 0.0, 140.0]))
    assert plate.sum() > 150 and render.mask[plate].all()
    assert np.mean(grey[plate] > 150) > 0.10 and np.mean(grey[below] > 150) < 0.02


def _full_frame_render(
    model_id: int, pose: CarPose, camera: PinholeCamera, background: np.ndarray
) -> tuple[np.ndarray, Box | None]:
    """The car drawn as before the renderer kept to the car's region: a supersampled layer of the whole
    frame, and both shadows filled and blurred over the whole frame."""
    model, lighting, strength = model_by_id(model_id), Lighting(), 0.55
    faces = _projected_faces(model, WHITE_RGB, pose, camera, lighting)
    car_bgr, coverage = _rasterise(faces, Box(0, 0, camera.width_px, camera.height_px), 3)
    image = background.astype(np.float32)
    light = np.asarray(lighting.direction)
    away_mm = -light[:2] / np.linalg.norm(light[:2]) * min(0.35 / max(light[2], 0.25), 1.2) * 400.0
    for scale, shift, blur_frac, weight in ((1.08, 1.0, 0.05, strength), (0.96, 0.0, 0.02, strength * 0.7)):
        shadow = np.zeros(background.shape[:2], np.float32)
        corners = pose.car_to_world(footprint_car_mm(model) * [scale, scale, 0.0])
        corners[:, :2] += away_mm * shift
        fill_world_polygon(shadow, camera, corners, (1.0,))
        if shadow.any():
            box = Box.tight(shadow > 0)
            shadow = cv2.GaussianBlur(shadow, (0, 0), max(1.0, blur_frac * max(box.width_px - 1, box.height_px - 1)))
            image *= (1.0 - weight * shadow)[:, :, None]
    image = image * (1.0 - coverage[:, :, None]) + car_bgr
    return np.clip(np.round(image), 0, 255).astype(np.uint8), Box.tight(coverage >= 0.5)


@pytest.mark.parametrize(
    ("model_id", "pose"),
    [(9, CarPose(548.0, 4147.0, 23.92)), (12, CarPose(-4800.0, 2500.0, 80.0)), (4, CarPose(6800.0, 6000.0, 10.0)),
     (11, CarPose(0.0, 30000.0, -90.0))],
    ids=["inside", "cut_left_bottom", "cut_right", "far"],
)
def test_drawing_only_the_cars_region_equals_the_full_frame_render(model_id: int, pose: CarPose) -> None:
    """Over a textured road seen by the Table 2 camera (at half size), the render restricted to the car's
    and its shadow's region equals the full-frame render within 1 grey level everywhere, with the same box."""
    camera = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 500.0, 640, 360)
    background = np.random.default_rng(0).integers(60, 200, (360, 640, 3), dtype=np.uint8)
    render = render_car(model_by_id(model_id), WHITE_RGB, pose, camera, background)
    reference, box = _full_frame_render(model_id, pose, camera, background)
    assert np.abs(render.image_bgr.astype(int) - reference).max() <= 1
    assert render.box == box is not None
