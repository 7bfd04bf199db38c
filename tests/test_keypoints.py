"""The key-point geometry of the paper's placement against exact ground truth from a pinhole camera: a
horizontal line at a height mapped to the road and lowered back, O below the plate, the heading from the
plate's edges, the bumper's height from a shape."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import LOW_VERGE
from vehloc.config import ConfigError
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.keypoints import (
    DetectorParams,
    below_plate_mm,
    end_bottom_height_mm,
    implausible_plate,
    lowered_line_mm,
    Placement,
    best_overlap,
    plate_width_heading_deg,
    plate_widths_mm,
)
from vehloc.data.boxes import Box
from vehloc.geometry.model_fit import silhouette
from vehloc.geometry.placement import between_axles, direction_of, facing, place_on_end, place_on_side
from vehloc.geometry.plate import Plate, PlateParams
from vehloc.geometry.camera_calibration import CameraCalibration


@pytest.fixture(scope="module")
def camera() -> PinholeCamera:
    return PinholeCamera.look_at(np.array([1500.0, -2000.0, 6500.0]), np.array([0.0, 12000.0, 0.0]), 1000.0, 1280, 720)


def _road_line_through(points_mm: np.ndarray) -> np.ndarray:
    line = np.cross([*points_mm[0], 1.0], [*points_mm[1], 1.0])
    return line / np.hypot(line[0], line[1])


@pytest.mark.parametrize("height_mm", [0.0, 185.0, 450.0])
def test_a_line_at_a_height_mapped_to_the_road_is_lowered_onto_the_line_below_it(camera: PinholeCamera,
                                                                                   height_mm: float) -> None:
    """A horizontal 3D line at `height_mm`, imaged and mapped to the road by the homography, lowered: the road
    line straight below it (both its points within 1e-6 mm)."""
    below = np.array([[-900.0, 9000.0], [1100.0, 9300.0]])
    image_px = camera.project(np.c_[below, np.full(2, height_mm)])
    as_if_on_road = camera.road_to_image().inverse(image_px)
    lowered = lowered_line_mm(_road_line_through(as_if_on_road), height_mm, camera.centre_mm)
    assert np.abs(below @ lowered[:2] + lowered[2]).max() / np.hypot(*lowered[:2]) < 1e-6


def test_o_is_the_footprint_point_below_the_plate(camera: PinholeCamera) -> None:
    """The plate's middle 450 mm above (300, 9000), mapped to the road as if on it, and the front line through
    (300, 9000): O is (300, 9000) within 1e-6 mm."""
    plate_px = camera.project(np.array([[300.0, 9000.0, 450.0]]))
    p_mm = camera.road_to_image().inverse(plate_px)[0]
    front_line = _road_line_through(np.array([[-700.0, 9000.0], [1300.0, 9000.0]]))
    np.testing.assert_allclose(below_plate_mm(p_mm, front_line, camera.centre_mm[:2]), [300.0, 9000.0], atol=1e-6)


def _plate_seen(camera: PinholeCamera, heading_deg: float, width_mm: float = 440.0, bottom_mm: float = 300.0,
                middle_mm: tuple[float, float] = (300.0, 9000.0)) -> Plate:
    """The image of a `width_mm` x 140 mm plate `bottom_mm` above the road (440 mm wide, 300-440 mm high unless
    told) on the end of a vehicle whose length axis runs along `heading_deg`, its middle at `middle_mm`."""
    across = np.array([-np.sin(np.radians(heading_deg)), np.cos(np.radians(heading_deg))])
    corners_mm = [np.r_[np.array(middle_mm) + s * width_mm / 2 * across, z]
                  for s, z in ((-1, bottom_mm + 140.0), (1, bottom_mm + 140.0), (1, bottom_mm), (-1, bottom_mm))]
    corners_px = camera.project(np.array(corners_mm))

    def line(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        homogeneous = np.cross([*a, 1.0], [*b, 1.0])
        return homogeneous / np.hypot(*homogeneous[:2])

    return Plate(corners_px, corners_px.mean(axis=0), line(*corners_px[:2]), line(*corners_px[2:]), 1.0)


@pytest.mark.parametrize("heading_deg", [90.0, 60.0, 120.0, 0.0])
def test_the_plates_edges_give_the_length_axis(camera: PinholeCamera, heading_deg: float) -> None:
    """The plate's upper and lower edges, imaged at their heights and mapped to the road as if on it, run
    across the length axis: the heading within 1e-6 deg."""
    plate = _plate_seen(camera, heading_deg)
    width_deg = plate_width_heading_deg(plate, camera.road_to_image())
    assert abs((width_deg - heading_deg - 90.0 + 90.0) % 180.0 - 90.0) < 1e-6


@pytest.mark.parametrize("turned_deg", [3.0, 12.0, -12.0])
def test_of_two_placements_the_one_whose_shape_the_silhouette_covers_is_chosen(camera: PinholeCamera,
                                                                                 turned_deg: float) -> None:
    """A cuboid car's exact silhouette (4.5 x 1.8 x 1.45 m, 11 m down the road, length axis at 93 deg): of its true
    box and the box turned about its visible end by `turned_deg`, the true one is chosen, whichever comes first."""
    shape = VehicleShape.cuboid(4500.0, 1800.0, 1450.0)
    end_mm = np.array([300.0, 11000.0])
    placed = [Placement(place_on_end(end_mm, direction_of(93.0 + turn), 4500.0, 1800.0), "plate", end_mm, end_mm, 0.0)
              for turn in (0.0, turned_deg)]
    roi = Box(0, 0, 1280, 720)
    mask = silhouette(camera, shape, placed[0].box, roi, 1)
    assert best_overlap(placed, camera, shape, roi, mask) is placed[0]
    assert best_overlap(placed[::-1], camera, shape, roi, mask) is placed[0]


@pytest.mark.parametrize(("heading_deg", "bottom_mm"), [(90.0, 300.0), (60.0, 0.0), (120.0, 1000.0)])
def test_a_plates_lower_edge_on_the_road_bounds_its_width(camera: PinholeCamera, heading_deg: float,
                                                          bottom_mm: float) -> None:
    """A 440-mm plate whose lower edge is `bottom_mm` high, from a camera 6.5 m high: its lower edge mapped to the
    road is 440 H / (H - h) long, the widest it can be; a plate mounted 1.2 m high would be H - 1.2 m over H of
    that (both within 1e-6 mm). It is a plate by its size."""
    camera_height_mm = camera.centre_mm[2]
    widths = plate_widths_mm(_plate_seen(camera, heading_deg, bottom_mm=bottom_mm), camera.road_to_image(),
                             camera_height_mm, 1200.0)
    on_road_mm = 440.0 * camera_height_mm / (camera_height_mm - bottom_mm)
    np.testing.assert_allclose(widths, [on_road_mm * (1.0 - 1200.0 / camera_height_mm), on_road_mm], atol=1e-6)
    calibration = CameraCalibration(camera.road_to_image(), (1280, 720), camera, 0.5, "test camera")
    assert implausible_plate(_plate_seen(camera, heading_deg, bottom_mm=bottom_mm), calibration,
                             PlateParams.from_config()) is None


def test_a_part_no_plate_can_be_is_not_a_plate(camera: PinholeCamera) -> None:
    """A plate-like part 1.4 m wide at the top of a windscreen (1.4 m high) is wider than any plate at any
    mounting height: 1400 x 6500 / 5100 = 1784 mm on the road, 1455 mm had it been 1.2 m high; one 200 mm wide
    on the road is narrower (163-200 mm); one beyond the horizon has no size on the road."""
    calibration = CameraCalibration(camera.road_to_image(), (1280, 720), camera, 0.5, "test camera")
    params = PlateParams.from_config()
    roof = implausible_plate(_plate_seen(camera, 90.0, width_mm=1400.0, bottom_mm=1400.0), calibration, params)
    narrow = implausible_plate(_plate_seen(camera, 90.0, width_mm=200.0, bottom_mm=0.0), calibration, params)
    assert roof.startswith("a plate-like part would be 1455-1784 mm wide, not 300-530 mm")
    assert narrow.startswith("a plate-like part would be 163-200 mm wide")
    skyward = _plate_seen(camera, 90.0, middle_mm=(0.0, 9000.0))
    skyward = dataclasses.replace(skyward, corners_px=skyward.corners_px - [0.0, 700.0])
    assert implausible_plate(skyward, calibration, params) == "a plate-like part's lower edge lies above the horizon"


def test_the_end_bottom_height_is_the_lowest_point_near_that_end() -> None:
    nose = np.array([[2000.0, -800, 300], [2000, 800, 300], [2100, -800, 320], [2100, 800, 320], [1900, 0, 900]])
    tail = np.array([[-2100.0, -800, 250], [-2100, 800, 250], [-2000, 0, 800]])
    shape = VehicleShape((np.vstack([nose, tail]),))
    assert end_bottom_height_mm(shape, "front") == 300.0
    assert end_bottom_height_mm(shape, "rear") == 250.0
    assert end_bottom_height_mm(shape, None) == 275.0


def test_a_plate_setting_out_of_range_is_named_before_any_work() -> None:
    defaults = DetectorParams.from_config()
    groups = {name: dataclasses.asdict(getattr(defaults, name)) for name in ("footprint", "plate", "wheels")}
    groups["plate"]["min_score"] = -1.0
    with pytest.raises(ConfigError, match=r"plate\.min_score: must be in \[0, 1\], got -1.0"):
        DetectorParams.from_mapping(groups)
    groups["plate"] |= {"min_score": 0.5, "width_range_mm": [530.0, 300.0]}
    with pytest.raises(ConfigError, match=r"plate\.width_range_mm\[1\]: must be >= 530, got 300.0"):
        DetectorParams.from_mapping(groups)


def test_a_shapes_axles_middle_is_its_tyres_and_a_cuboids_is_its_own() -> None:
    """The axles' middle along the car is the mean of the tyres' x-middles (the parts standing on the road): for every
    catalog model exactly its axles' (a Toyota Hilux's 222.5 mm ahead of its footprint's centre, a Volvo C30's 67 mm
    behind); a cuboid, with no tyres apart from its body, has it at its centre (the paper's assumption)."""
    from vehloc.synth.body import catalog_shapes
    from vehloc.synth.catalog import CATALOG

    shapes = catalog_shapes()
    for model in CATALOG:
        expected_mm = (model.front_axle_x_mm + model.rear_axle_x_mm) / 2
        assert shapes[model.model_id].axle_middle_x_mm == pytest.approx(expected_mm, abs=1e-9)
    assert {m.model: round(shapes[m.model_id].axle_middle_x_mm, 1) for m in CATALOG}["Hilux"] == 222.5
    assert VehicleShape.cuboid(4500.0, 1800.0, 1450.0).axle_middle_x_mm == 0.0


@pytest.mark.parametrize("heading_deg", [0.0, 35.0, -120.0])
def test_a_wheel_placement_moved_between_the_axles_puts_their_middle_on_q(heading_deg: float) -> None:
    """A box placed with its side's middle on Q and moved by the axles' middle (200 mm ahead): the point of its near
    side at the axles' middle is Q again to 1e-9 mm, its heading and size unchanged."""
    q_mm, inward_dir = np.array([1000.0, 20000.0]), direction_of(heading_deg - 90.0)
    box = place_on_side(q_mm, inward_dir, 5000.0, 1900.0)
    box = facing(box, heading_deg)
    moved = between_axles(box, 200.0)
    near_side_at_axles = moved.centre_mm + moved.forward * 200.0 - inward_dir * moved.width_mm / 2
    assert np.allclose(near_side_at_axles, q_mm, atol=1e-9)
    assert (moved.heading_deg, moved.length_mm, moved.width_mm) == (box.heading_deg, box.length_mm, box.width_mm)


def _silhouette_mask(camera: PinholeCamera, box, height_mm: float) -> np.ndarray:
    """The frame's pixels covered by a cuboid standing on the box's footprint."""
    import cv2

    corners = box.corners_mm()
    points = camera.project(np.vstack([np.c_[corners, np.zeros(4)], np.c_[corners, np.full(4, height_mm)]]))
    mask = np.zeros((camera.height_px, camera.width_px), np.uint8)
    cv2.fillConvexPoly(mask, np.round(cv2.convexHull(points.astype(np.float32))).astype(np.int32), 1)
    return mask.astype(bool)


@pytest.mark.parametrize("heading_deg", [15.0, 100.0, 200.0])
@pytest.mark.parametrize("axle", [-1.0, 1.0])
def test_one_wheel_puts_q_half_a_wheelbase_from_it_towards_the_body(camera: PinholeCamera, heading_deg: float,
                                                                     axle: float) -> None:
    """The near side's front or rear outer tyre contact of a box whose axles' middle is its centre, imaged
    exactly, and the true length axis: the box is placed on that centre within 1e-6 mm and along that axis (the
    body's silhouette, a cuboid, says which way the other axle lies)."""
    from vehloc.data.specs import VehicleSpec
    from vehloc.geometry.keypoints import one_wheel_placement
    from vehloc.geometry.placement import VehicleBox, axis_difference_deg

    spec = VehicleSpec(9, "Make", "Model", 4800.0, 1850.0, 1450.0, 2800.0)
    truth = VehicleBox(np.array([800.0, 11000.0]), heading_deg, spec.length_mm, spec.width_mm)
    along, across = direction_of(heading_deg), direction_of(heading_deg + 90.0)
    sides = [truth.centre_mm + sign * across * spec.width_mm / 2 for sign in (-1.0, 1.0)]
    near = min(sides, key=lambda p: np.linalg.norm(p - camera.centre_mm[:2]))
    contact_px = camera.project(np.array([[*(near + axle * along * spec.wheelbase_mm / 2), 0.0]]))[0]
    calibration = CameraCalibration(camera.road_to_image(), (camera.width_px, camera.height_px), camera, 0.0, "exact")
    mask = _silhouette_mask(camera, truth, spec.height_mm)
    placed = one_wheel_placement(contact_px, heading_deg % 180.0, mask, np.zeros(2), calibration, spec, 0.1)
    assert placed.kind == "wheel"
    np.testing.assert_allclose(placed.box.centre_mm, truth.centre_mm, atol=1e-6)
    assert abs(axis_difference_deg(placed.box.heading_deg, heading_deg)) < 1e-9


def test_one_wheel_whose_box_leaves_the_silhouette_is_no_placement(camera: PinholeCamera) -> None:
    """A 'wheel' 4 m ahead of the body (a contact no wheel of it has): its box would reach beyond the silhouette's
    bounding box grown by a tenth, so it is not placed, and the reason says by how far."""
    from vehloc.data.specs import VehicleSpec
    from vehloc.geometry.keypoints import one_wheel_placement
    from vehloc.geometry.outcome import NotPlaced
    from vehloc.geometry.placement import VehicleBox

    spec = VehicleSpec(9, "Make", "Model", 4800.0, 1850.0, 1450.0, 2800.0)
    truth = VehicleBox(np.array([800.0, 11000.0]), 15.0, spec.length_mm, spec.width_mm)
    ahead_mm = truth.centre_mm + direction_of(15.0) * (spec.length_mm / 2 + 4000.0)
    contact_px = camera.project(np.array([[*ahead_mm, 0.0]]))[0]
    calibration = CameraCalibration(camera.road_to_image(), (camera.width_px, camera.height_px), camera, 0.0, "exact")
    placed = one_wheel_placement(contact_px, 15.0, _silhouette_mask(camera, truth, spec.height_mm), np.zeros(2),
                                 calibration, spec, 0.1)
    assert isinstance(placed, NotPlaced) and "px beyond the vehicle's silhouette" in placed.message


def _contacts(camera: PinholeCamera, centre_mm: list[float], heading_deg: float, wheelbase_mm: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """A side's two tyre contacts on the road (2, 2) about `centre_mm` and their exact images."""
    half = direction_of(heading_deg) * wheelbase_mm / 2
    road_mm = np.stack([np.asarray(centre_mm) - half, np.asarray(centre_mm) + half])
    return road_mm, camera.road_to_image()(road_mm)


@pytest.mark.parametrize("heading_deg", [10.0, 60.0, 100.0, 150.0])
@pytest.mark.parametrize("centre_mm", [[0.0, 12000.0], [-2000.0, 34000.0]])
def test_contacts_imaged_exactly_are_held_where_they_are(heading_deg: float, centre_mm: list[float]) -> None:
    """Two contacts a wheelbase apart, imaged exactly: holding them at that wheelbase leaves them where they are
    (within 1e-6 mm)."""
    from vehloc.geometry.keypoints import held_at_wheelbase

    road_to_image = LOW_VERGE.road_to_image()
    road_mm, image_px = _contacts(LOW_VERGE, centre_mm, heading_deg, 2800.0)
    held = held_at_wheelbase(image_px, road_to_image.inverse(image_px), road_to_image, 2800.0)
    np.testing.assert_allclose(held, road_mm, atol=1e-6)


@pytest.mark.parametrize("heading_deg", [60.0, 150.0])
def test_a_far_pairs_direction_is_held_by_the_wheelbase(heading_deg: float) -> None:
    """A car 34 m down the road from the low verge camera, its contacts 39-41 px apart in the image, each read 0.7 px off
    vertically (opposite ways): mapped to the road as read, their direction is over 6 deg off; held at the
    wheelbase, within 0.5 deg (measured 6.33 and 6.46 deg, and 0.38 and 0.22 deg)."""
    from vehloc.geometry.keypoints import held_at_wheelbase
    from vehloc.geometry.placement import axis_difference_deg, heading_of

    road_to_image = LOW_VERGE.road_to_image()
    _, image_px = _contacts(LOW_VERGE, [-2000.0, 34000.0], heading_deg, 2800.0)
    read_px = image_px + [[0.0, 0.7], [0.0, -0.7]]
    as_read = road_to_image.inverse(read_px)
    held = held_at_wheelbase(read_px, as_read, road_to_image, 2800.0)
    assert abs(axis_difference_deg(heading_of(as_read[1] - as_read[0]), heading_deg)) > 6.0
    assert abs(axis_difference_deg(heading_of(held[1] - held[0]), heading_deg)) < 0.5
    assert np.linalg.norm(held[1] - held[0]) == pytest.approx(2800.0, abs=1e-6)
