"""A vehicle's speed: the constant-velocity fit (exact on an exact path, strays dropped, its sigma), the footprint
centre from a box's edge and the model's shape, and the speed benchmark's projection (vanishing points, principal
point, scale) against exact ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.box_reference import centre_from_box, shape_edge_px
from vehloc.geometry.brno import brno_calibration, focal_and_road_plane, project_to_metres
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import shape_points_world
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.speed import SpeedFit, fit_speed

FPS = 25.0


def _path(speed_kmh: float, frames: int, heading_deg: float = -90.0) -> tuple[np.ndarray, np.ndarray]:
    times = np.arange(frames) / FPS
    direction = np.array([np.cos(np.radians(heading_deg)), np.sin(np.radians(heading_deg))])
    return np.array([1000.0, 60000.0]) + np.outer(times * speed_kmh / 3.6 * 1000.0, direction), times


def test_an_exact_path_gives_its_speed_and_heading_exactly() -> None:
    points, times = _path(87.5, 40, heading_deg=-80.0)
    fit = fit_speed(points, times, scale_sigma_fraction=0.0, min_points=6, min_distance_mm=3000.0)
    assert isinstance(fit, SpeedFit)
    assert fit.speed_kmh == pytest.approx(87.5, rel=1e-12)
    assert fit.heading_deg == pytest.approx(-80.0, abs=1e-9)
    assert fit.fit_sigma_kmh == pytest.approx(0.0, abs=1e-9) and fit.dropped == 0 and fit.used.all()


def test_a_box_that_held_a_neighbour_for_a_third_of_the_path_does_not_move_the_speed() -> None:
    rng = np.random.default_rng(3)
    points, times = _path(100.0, 60)
    points = points + rng.normal(0.0, 80.0, points.shape)  # the box's wander, mm
    points[20:40] += np.linspace([2000.0, 6000.0], [2500.0, 16000.0], 20)  # merged with the car beside it
    fit = fit_speed(points, times, 0.0, 6, 3000.0)
    assert isinstance(fit, SpeedFit)
    assert fit.speed_kmh == pytest.approx(100.0, rel=0.005)  # tolerance: 0.5 % with 80 mm of wander
    assert not fit.used[20:40].any() and fit.used[:20].all() and fit.used[40:].all()


def test_the_sigma_has_the_fit_and_the_scale_in_it() -> None:
    rng = np.random.default_rng(4)
    points, times = _path(60.0, 50)
    noisy = fit_speed(points + rng.normal(0.0, 100.0, points.shape), times, 0.01, 6, 3000.0)
    assert isinstance(noisy, SpeedFit)
    assert noisy.scale_sigma_kmh == pytest.approx(0.01 * noisy.speed_kmh)
    assert noisy.sigma_kmh == pytest.approx(np.hypot(noisy.fit_sigma_kmh, noisy.scale_sigma_kmh))
    # the velocity's standard error: 100 mm over sqrt(sum (t - mean t)^2), in km/h
    expected = 100.0 / np.sqrt(np.sum((times - times.mean()) ** 2)) * 3.6e-3
    assert noisy.fit_sigma_kmh == pytest.approx(expected, rel=0.3)


@pytest.mark.parametrize(("frames", "speed_kmh", "why"), [(4, 100.0, "usable point"), (30, 2.0, "steady motion covers")])
def test_a_short_path_is_a_reason_not_a_speed(frames: int, speed_kmh: float, why: str) -> None:
    points, times = _path(speed_kmh, frames)
    result = fit_speed(points, times, 0.0, 6, 3000.0)
    assert isinstance(result, NotPlaced) and result.code == ReasonCode.PATH_TOO_SHORT and why in result.message


CAMERA = PinholeCamera.look_at((-7000.0, -4000.0, 9000.0), (0.0, 24000.0, 0.0), 1100.0, 1280, 720, 0.0)
SHAPE = VehicleShape((np.array([[x, y, z] for x in (-2300.0, 2300.0) for y in (-900.0, 900.0) for z in (300.0, 700.0)]),
                      np.array([[x, y, z] for x in (-1200.0, 800.0) for y in (-750.0, 750.0) for z in (700.0, 1450.0)])))
"""A car's body (300-700 mm up) and cabin (up to 1450 mm): neither of its box's edges is on the road."""


def _box_of(centre_mm: np.ndarray, heading_deg: float) -> Box:
    """The box of the pixels the shape covers at least half (first column/row at ceil, last at floor)."""
    pixels = CAMERA.project(shape_points_world(SHAPE, VehicleBox(centre_mm, heading_deg, 0.0, 0.0)))
    return Box(int(np.ceil(pixels[:, 0].min())), int(np.ceil(pixels[:, 1].min())),
               int(np.floor(pixels[:, 0].max())) + 1, int(np.floor(pixels[:, 1].max())) + 1)


@pytest.mark.parametrize("edge", ["top", "bottom"])
@pytest.mark.parametrize("centre", [(-3500.0, 15000.0), (0.0, 30000.0), (3500.0, 50000.0)])
def test_the_footprint_centre_from_a_box_edge_is_the_true_one(edge: str, centre: tuple[float, float]) -> None:
    true_centre = np.array(centre)
    box = _box_of(true_centre, -90.0)
    start = CAMERA.image_to_road(np.array([[box.centre_px[0], box.y1 - 1.0]]))[0]  # the road point under the bottom
    found = centre_from_box(CAMERA, SHAPE, box, -90.0, start, edge)
    assert not isinstance(found, NotPlaced)
    # tolerance: the box's edges are whole pixels; one pixel of the edge's row spans this much road along Y
    one_row_mm = abs(np.diff(CAMERA.image_to_road(np.array([[box.centre_px[0], box.y1 - 1.0],
                                                              [box.centre_px[0], box.y1]]))[:, 1])[0])
    assert np.linalg.norm(found - true_centre) < one_row_mm * 1.5
    # and it is the shape's edge at the found centre that meets the box's
    assert shape_edge_px(CAMERA, SHAPE, found, -90.0, edge)[1] == pytest.approx(box.y0 if edge == "top" else box.y1 - 1.0,
                                                                               abs=1e-3)


def test_the_benchmark_projection_of_a_calibrated_camera_gives_road_distances_in_metres() -> None:
    road = np.array([[x, y] for x in (-5000.0, 0.0, 5000.0) for y in (10000.0, 25000.0, 50000.0)])
    calibration = brno_calibration(CAMERA, CAMERA.road_to_image(), road)
    focal, _ = focal_and_road_plane(np.array(calibration.vp1_px), np.array(calibration.vp2_px),
                                    np.array(calibration.pp_px))
    assert focal == pytest.approx(1100.0, rel=1e-9)  # the scorer's focal from the two vanishing points
    metres = project_to_metres(CAMERA.road_to_image()(road), calibration)
    for i, j in [(0, 8), (1, 5), (2, 6)]:
        assert np.linalg.norm(metres[i] - metres[j]) == pytest.approx(np.linalg.norm(road[i] - road[j]) / 1000.0,
                                                                      rel=1e-9)


def test_a_camera_looking_square_down_the_road_cannot_be_written_in_the_benchmark_model() -> None:
    square = PinholeCamera.look_at((0.0, -4000.0, 9000.0), (0.0, 24000.0, 0.0), 1100.0, 1280, 720, 0.0)
    with pytest.raises(ValueError, match="vanishing point is at infinity"):
        brno_calibration(square, square.road_to_image(), np.array([[0.0, 10000.0], [0.0, 20000.0]]))


def _vehicle(track_id: int, lateral_mm: float, measured: bool = True):
    from vehloc.geometry.pipeline.track_speed import VehiclePath, VehicleSpeed
    from vehloc.geometry.speed import fit_speed

    points = np.column_stack([np.full(5, lateral_mm), np.linspace(40000.0, 10000.0, 5)])
    speed = fit_speed(points, np.arange(5) / FPS, 0.0, 3, 1000.0) if measured else NotPlaced(
        ReasonCode.PATH_TOO_SHORT, "unused")
    return VehicleSpeed(track_id, 0, 4, FPS, VehiclePath(np.arange(5), points, points, np.zeros((5, 4), int)), speed)


def test_lanes_come_from_the_sites_lines_or_from_the_paths_clusters() -> None:
    from vehloc.geometry.pipeline.track_speed import SpeedParams, assign_lanes

    vehicles = [_vehicle(i, x) for i, x in enumerate([-3600.0, 150.0, -3300.0, 3400.0, 9000.0, -200.0])]
    lines = SpeedParams.from_config(lane_lines_x_mm=[-5250.0, -1750.0, 1750.0, 5250.0])
    assert [v.lane for v in assign_lanes(vehicles, lines)] == [0, 1, 0, 2, None, 1]  # 9 m across: off the road
    clustered = SpeedParams.from_config(lane_gap_mm=1500.0)
    assert [v.lane for v in assign_lanes(vehicles, clustered)] == [0, 1, 0, 2, 3, 1]


def test_fragments_without_a_speed_do_not_join_two_lanes() -> None:
    """Two lanes of measured cars 3.4 m apart, and fragments without a speed spread between them every 0.5 m (which
    would chain the lanes into one): the lanes stay two, a fragment within 1.5 m of a measured car takes its lane, one
    farther from every measured car has none."""
    from vehloc.geometry.pipeline.track_speed import SpeedParams, assign_lanes

    measured = [_vehicle(i, x) for i, x in enumerate([-1900.0, -1500.0, -1200.0, 1400.0, 1700.0])]
    fragments = [_vehicle(10 + i, x, measured=False) for i, x in enumerate(np.arange(-1000.0, 1300.0, 500.0))]
    lanes = [v.lane for v in assign_lanes(measured + fragments, SpeedParams.from_config(lane_gap_mm=1500.0))]
    assert lanes[:5] == [0, 0, 0, 1, 1]
    assert lanes[5:] == [0, 0, 0, 1, 1]  # -1000, -500, 0 (1.2 m from -1200), 500, 1000 (0.9 m from 1400)
    far = assign_lanes(measured + [_vehicle(20, 6000.0, measured=False)], SpeedParams.from_config(lane_gap_mm=1500.0))
    assert far[-1].lane is None
