"""A camera from its traffic, piece by piece against exact truth: vanishing points from segments (finite, at infinity,
none), the camera from two vanishing points, the camera's height from a vehicle's box and shape, the combination
over vehicles, points tracked on a moving pattern, and `vehloc-calibrate mode=auto` refusing what it cannot do."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from bad_input import assert_one_error, run_cli, write_handmade_onnx

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.auto_calibration import (
    box_sides_px,
    camera_at_height,
    camera_from_horizon,
    camera_from_vanishing_points,
    combine_heights,
    focal_from_vanishing_points,
    height_from_sides,
    horizon_through,
)
from vehloc.geometry.brno import vanishing_point_px
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import shape_points_world
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.roi import Silhouette
from vehloc.geometry.traffic_evidence import FeatureParams, FeatureTracks, sure_outline
from vehloc.geometry.outcome import FailedEstimate
from vehloc.geometry.vanishing import Segments, VanishingPoint, find_vanishing_point

CAMERAS = {
    "beside the road": PinholeCamera.look_at((-7000.0, -4000.0, 9000.0), (0.0, 24000.0, 0.0), 1100.0, 1280, 720, 0.0),
    "rolled, turned": PinholeCamera.look_at((-11276.0, 1019.0, 12000.0), (0.0, 32000.0, 0.0), 2317.6, 1920, 1080, 2.0),
    "steep, wide": PinholeCamera.look_at((-936.0, 12148.0, 15000.0), (0.0, 30000.0, 0.0), 960.0, 1920, 1080, -1.0),
}


def _homogeneous(point_px: np.ndarray) -> np.ndarray:
    return np.append(point_px, 1.0)


def _segments_towards(point_px: np.ndarray, count: int, rng: np.random.Generator, noise_deg: float = 0.0) -> Segments:
    points = rng.uniform(0, 1000, (count, 2))
    directions = point_px - points
    angles = np.arctan2(directions[:, 1], directions[:, 0]) + np.radians(rng.normal(0, noise_deg, count) if noise_deg else 0)
    return Segments(points, np.column_stack([np.cos(angles), np.sin(angles)]), rng.uniform(10, 50, count))


def test_a_vanishing_point_is_found_through_outliers() -> None:
    rng = np.random.default_rng(0)
    target = np.array([700.0, -300.0])
    outliers = Segments(rng.uniform(0, 1000, (30, 2)), np.tile([np.cos(1.0), np.sin(1.0)], (30, 1)),
                        rng.uniform(10, 50, 30))  # parallel to each other, not towards the point
    found = find_vanishing_point(Segments.join([_segments_towards(target, 60, rng), outliers]), 1.0, 0.3)
    assert isinstance(found, VanishingPoint)
    # exact segments: the point to 1e-6 px, the 30 parallel outliers left out
    assert np.allclose(found.point_px, target, atol=1e-6)
    assert found.inliers[:60].all() and not found.inliers[60:].any()
    noisy = find_vanishing_point(_segments_towards(target, 200, rng, noise_deg=0.2), 1.0, 0.3)
    assert np.linalg.norm(noisy.point_px - target) < 5.0  # 0.2 deg of noise, 200 segments: within 5 px


def test_parallel_segments_meet_at_infinity_and_scattered_ones_nowhere() -> None:
    rng = np.random.default_rng(1)
    parallel = Segments(rng.uniform(0, 500, (20, 2)), np.tile([1.0, 0.0], (20, 1)), np.ones(20))
    found = find_vanishing_point(parallel, 1.0, 0.3)
    assert found and found.at_infinity and np.all(np.isinf(found.point_px))
    angles = rng.uniform(0, np.pi, 40)
    scattered = Segments(rng.uniform(0, 500, (40, 2)), np.column_stack([np.cos(angles), np.sin(angles)]), np.ones(40))
    assert isinstance(find_vanishing_point(scattered, 0.5, 0.5), FailedEstimate)
    one = find_vanishing_point(parallel.subset(np.arange(20) < 1), 1.0, 0.3)
    assert isinstance(one, FailedEstimate) and not one and "too few" in str(one)


def _assert_the_same_road(camera: PinholeCamera, truth: PinholeCamera) -> None:
    """The same road: distances between road points through the true camera's pixels, to 1e-6 relative; and the same
    tilt and roll (world frames differ only by a turn about the vertical and a shift)."""
    road = np.array([[x, y] for x in (-3500.0, 0.0, 3500.0) for y in (20000.0, 30000.0, 40000.0)])
    back = camera.image_to_road(truth.road_to_image()(road))
    first, second = np.triu_indices(len(road), k=1)
    true_mm = np.linalg.norm(road[first] - road[second], axis=1)
    assert np.allclose(np.linalg.norm(back[first] - back[second], axis=1), true_mm, rtol=1e-6)
    assert np.isclose(camera.R[2, 2], truth.R[2, 2], atol=1e-9) and np.isclose(camera.R[0, 2], truth.R[0, 2], atol=1e-9)


@pytest.mark.parametrize("name", CAMERAS)
def test_the_camera_follows_from_its_two_vanishing_points(name: str) -> None:
    truth = CAMERAS[name]
    vp1, vp2 = (_homogeneous(vanishing_point_px(truth, d)) for d in ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0]))
    camera = camera_from_vanishing_points(vp1, vp2, truth.K[:2, 2], float(truth.centre_mm[2]),
                                          (truth.width_px, truth.height_px))
    assert abs(camera.focal_px - truth.focal_px) < 1e-6 * truth.focal_px
    _assert_the_same_road(camera, truth)


@pytest.mark.parametrize("name", CAMERAS)
def test_a_known_focal_length_needs_only_the_horizon_s_direction(name: str) -> None:
    """Any point of the horizon other than the first vanishing point (here one 40 image widths further out than the
    second, where edges hardly converge), with the lens's focal length, gives the true camera."""
    truth = CAMERAS[name]
    vp1, vp2 = (vanishing_point_px(truth, d) for d in ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0]))
    far = vp1 + (vp2 - vp1) * (1.0 + 40.0 * truth.width_px / np.linalg.norm(vp2 - vp1))
    horizon = horizon_through(_homogeneous(vp1), _homogeneous(far))
    camera = camera_from_horizon(_homogeneous(vp1), horizon, truth.K[:2, 2], truth.focal_px, float(truth.centre_mm[2]),
                                 (truth.width_px, truth.height_px))
    _assert_the_same_road(camera, truth)
    # the second vanishing point is the camera's image of the across direction: the true one
    across = camera.K @ camera.R[:, 0]
    assert np.allclose(across[:2] / across[2], vp2, atol=1e-6 * np.linalg.norm(vp2))


def test_no_focal_length_from_a_point_at_infinity_or_from_directions_not_perpendicular() -> None:
    pp = np.array([640.0, 360.0])
    at_infinity = focal_from_vanishing_points(np.array([300.0, 10.0, 1.0]), np.array([1.0, 0.0, 0.0]), pp)
    assert isinstance(at_infinity, FailedEstimate) and "infinity" in str(at_infinity)
    same_side = focal_from_vanishing_points(np.array([300.0, 10.0, 1.0]), np.array([100.0, 20.0, 1.0]), pp)
    assert isinstance(same_side, FailedEstimate) and "perpendicular" in str(same_side)


@pytest.mark.parametrize("name", CAMERAS)
def test_the_camera_height_from_one_box_and_its_shape(name: str) -> None:
    truth = CAMERAS[name]
    shape = VehicleShape.cuboid(4600.0, 1800.0, 1450.0)
    centre, heading = np.array([1000.0, 28000.0]), -90.0
    pixels = truth.project(shape_points_world(shape, VehicleBox(centre, heading, 0.0, 0.0)))
    top, left, right = box_sides_px(pixels)
    bottom = pixels[:, 1].max() - 0.5
    # the outline of whole pixels around the projected shape: its edges rounded, as a silhouette's
    sides, bottom = np.round([top, left, right]), float(np.round(bottom))
    vp1, vp2 = (_homogeneous(vanishing_point_px(truth, d)) for d in ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0]))
    unit = camera_from_vanishing_points(vp1, vp2, truth.K[:2, 2], 1000.0, (truth.width_px, truth.height_px))
    found = height_from_sides(unit, shape, sides, bottom, heading)
    assert found
    # rounding the edges moves them up to 0.5 px: on outlines 60-400 px wide, within 1.5 % of the true height
    assert abs(found.height_mm / truth.centre_mm[2] - 1.0) < 0.015
    assert abs(found.bottom_gap_px) <= 1.0  # the shape's bottom where the outline's is, to the rounding
    # the same estimate from a camera of any other height (the scene scales about the camera's foot)
    again = height_from_sides(camera_at_height(unit, 25000.0), shape, sides, bottom, heading)
    assert abs(again.height_mm / found.height_mm - 1.0) < 1e-4


def test_heights_combine_to_their_median_with_its_sigma() -> None:
    heights = np.array([9000.0, 9100.0, 8900.0, 9050.0, 8950.0, 12000.0])
    combined = combine_heights(heights, np.full(6, 0.05))
    assert combined.height_mm == 9025.0 and combined.vehicles == 6
    mad = np.median(np.abs(heights - 9025.0))
    assert np.isclose(combined.sigma_spread_mm, 1.4826 * mad * 1.2533 / np.sqrt(6))
    assert np.isclose(combined.sigma_classifier_mm, 9025.0 * 0.05 / np.sqrt(6))
    assert np.isclose(combined.sigma_mm, np.hypot(combined.sigma_spread_mm, combined.sigma_classifier_mm))


class _Vote:
    """A track's vote as `recognised_models` reads it: fixed class probabilities."""

    def __init__(self, probabilities: np.ndarray) -> None:
        self.empty, self.probabilities = False, probabilities

    def vote(self, classifier: object) -> np.ndarray:
        return self.probabilities


def test_an_unsure_vote_sizes_its_vehicle_by_the_expected_dimensions() -> None:
    """A vote that cannot tell a Fiat 500 from the sedans it also likes: "voted" takes the Fiat's size (it won by a
    hair), "expected" the top-5 probability-weighted dimensions; a sure vote gives the same either way."""
    from types import SimpleNamespace

    from vehloc.benchmark.oracle import TrueModelClassifier, catalog_metadata
    from vehloc.geometry.pipeline.auto_calibrate import recognised_models

    metadata = catalog_metadata()
    classifier = TrueModelClassifier(11, metadata)
    ids = [c.model_id for c in metadata.classes]
    unsure = np.full(len(ids), 0.02)
    unsure[[ids.index(11), ids.index(9), ids.index(7), ids.index(5), ids.index(3)]] = [0.2, 0.19, 0.18, 0.17, 0.16]
    unsure /= unsure.sum()
    track = SimpleNamespace(votes=_Vote(unsure))
    # a shape's body without its mirrors (150 mm a side)
    body_mm = lambda shape: np.ptp(shape.points_mm, axis=0) - [0.0, 300.0, 0.0]  # noqa: E731
    fiat = metadata.dims_mm[ids.index(11)]
    voted = recognised_models(classifier, "voted")(track)
    assert voted.label == "Fiat 500" and np.allclose(body_mm(voted.shape), fiat)
    expected = recognised_models(classifier, "expected")(track)
    top5 = [11, 9, 7, 5, 3]
    weights = np.array([0.2, 0.19, 0.18, 0.17, 0.16]) / 0.9
    wanted = weights @ metadata.dims_mm[[ids.index(i) for i in top5]]
    assert expected.label == "Fiat 500"
    # every part stretched by the same factors: the body to the expected dimensions, the mirrors with it (within 2 %
    # of the width)
    stretched = np.ptp(expected.shape.points_mm, axis=0)
    assert np.allclose(stretched[[0, 2]], wanted[[0, 2]], rtol=1e-9)
    assert abs(stretched[1] / (wanted[1] + 300.0) - 1.0) < 0.02
    # the size doubt is the vote's spread about the size given: smaller about the expected size than about the Fiat's
    assert 0.0 < expected.size_doubt < voted.size_doubt
    sure = SimpleNamespace(votes=_Vote(np.eye(len(ids))[ids.index(9)]))
    one, other = (recognised_models(classifier, size)(sure) for size in ("voted", "expected"))
    assert np.allclose(one.shape.points_mm, other.shape.points_mm) and one.size_doubt == other.size_doubt == 0.0
    with pytest.raises(ValueError, match="size"):
        recognised_models(classifier, "largest")


def test_points_tracked_on_a_moving_pattern_point_along_its_motion() -> None:
    rng = np.random.default_rng(3)
    texture = (rng.uniform(0, 255, (40, 60)) > 128).astype(np.uint8) * 200 + 30
    texture = cv2.resize(texture, (120, 80), interpolation=cv2.INTER_NEAREST)
    tracks = FeatureTracks(FeatureParams(100, 6.0, 0.3, 8, 15.0, 0.5))
    direction = np.array([np.cos(0.4), np.sin(0.4)])
    for step in range(30):
        frame = np.full((300, 400), 90, np.uint8)
        x, y = (np.array([40.0, 40.0]) + 4.0 * step * direction).astype(int)
        frame[y:y + 80, x:x + 120] = texture
        mask = np.zeros_like(frame)
        mask[y:y + 80, x:x + 120] = 255
        tracks.update(frame, mask, detect=step % 2 == 0)
    segments = tracks.finish()
    assert len(segments) >= 10
    # every straight path runs along the motion within 1 degree (whole-pixel steps: within 0.6 deg of 0.4 rad)
    cosines = np.abs(segments.directions @ direction)
    assert np.all(cosines > np.cos(np.radians(1.0)))


def test_calibrate_auto_refuses_a_video_without_traffic(tmp_path: Path) -> None:
    video = tmp_path / "empty_road.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (320, 240))
    road = np.random.default_rng(0).integers(60, 90, (240, 320, 3), dtype=np.uint8)
    for _ in range(180):
        writer.write(road)
    writer.release()
    model = write_handmade_onnx(tmp_path / "model.onnx", model_ids=(7, 9, 12))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "calibration.json").write_text("{\"kept\": true}")
    result = run_cli("vehloc-calibrate", "mode=auto", f"video={video}", f"model={model}",
                     f"hydra.run.dir={tmp_path / 'out'}")
    assert_one_error(result, "vehloc-calibrate", str(video), "no automatic calibration", "no vehicle seen moving straight")
    assert (tmp_path / "out" / "calibration.json").read_text() == "{\"kept\": true}"


@pytest.mark.parametrize(("overrides", "fragment"), [
    (["mode=auto"], "video=PATH is required with mode=auto"),
    (["mode=auto", "video=v.avi"], "model=PATH is required with mode=auto"),
    (["mode=auto", "video=v.avi", "model=m.onnx", "auto.min_vehicles=0"], "auto.min_vehicles: must be in [1, 100000]"),
    (["mode=auto", "video=v.avi", "model=m.onnx", "auto.scale_source=guess"], "auto.scale_source: expected one of"),
    (["mode=auto", "video=v.avi", "model=m.onnx", "auto.recognised_size=top"], "auto.recognised_size: expected one of"),
    (["mode=auto", "video=v.avi", "model=m.onnx", "auto.focal_px=-3"], "auto.focal_px: must be in (0, 1e+06]"),
    (["mode=auto", "video=v.avi", "model=m.onnx", 'localize=["roi.nope=1"]'], "Could not override 'roi.nope'"),
])
def test_calibrate_auto_checks_its_settings_first(overrides: list[str], fragment: str, tmp_path: Path) -> None:
    result = run_cli("vehloc-calibrate", *overrides, f"hydra.run.dir={tmp_path / 'out'}")
    assert_one_error(result, "vehloc-calibrate", fragment)
    assert not (tmp_path / "out" / "calibration.json").exists()


def test_the_scale_sigma_of_a_calibration_file_reaches_the_speeds_sigma(tmp_path: Path) -> None:
    import json

    from vehloc.geometry.calibration import CalibrationError
    from vehloc.geometry.camera_calibration import read_calibration
    from vehloc.geometry.pipeline.track_speed import SpeedParams, TrackSpeeds

    camera = CAMERAS["beside the road"]
    content = {"homography_world_mm_to_image_px": camera.road_to_image().normalised_matrix.tolist(),
               "image_size_px": [camera.width_px, camera.height_px], "rms_reprojection_px": 0.0,
               "scale_sigma_fraction": 0.02}
    (tmp_path / "calibration.json").write_text(json.dumps(content))
    calibration = read_calibration(tmp_path / "calibration.json")
    assert calibration.scale_sigma_fraction == 0.02
    speeds = TrackSpeeds(None, calibration, SpeedParams.from_config(), 25.0, 1.0, 2.0)
    path = np.array([[0.0, 20000.0], [0.0, 30000.0]])
    assert speeds.scale_sigma_fraction(path) == pytest.approx(0.02)  # no reprojection error: the scale's alone
    content["scale_sigma_fraction"] = -0.1
    (tmp_path / "calibration.json").write_text(json.dumps(content))
    with pytest.raises(CalibrationError, match="scale_sigma_fraction must be a finite number >= 0"):
        read_calibration(tmp_path / "calibration.json")


@pytest.mark.parametrize("doubt_weight", [0.5, 1.0])
def test_a_sure_outline_leaves_out_the_grainy_doubtful_pixels_whatever_they_weigh(doubt_weight: float):
    """The vehicle rows 10-29, columns 20-59 of an ROI at (100, 200); a grainy doubtful patch (a cast shadow) below it
    (rows 30-35) and to its right (columns 60-69), and a smooth doubtful face (solid) on its top rows 10-12: the
    outline is the vehicle's and its solid face, each extreme moved 0.5 px in, whatever the fit weighs the doubtful
    pixels."""
    mask = np.zeros((50, 80), bool)
    mask[10:36, 20:70] = True
    doubtful = np.zeros_like(mask)
    doubtful[30:36, 20:70] = doubtful[10:36, 60:70] = doubtful[10:13, 20:60] = True
    solid = mask & ~doubtful
    solid[10:13, 20:60] = True
    weights = np.where(mask, np.where(doubtful, doubt_weight, 1.0), 0.0)
    outline = sure_outline(Silhouette(mask, weights, doubtful, solid, np.ones(mask.shape, np.float32), 0), Box(100, 200, 180, 250), 0.5)
    np.testing.assert_array_equal(outline.sides_px, [200 + 10 + 0.5, 100 + 20 + 0.5, 100 + 59 - 0.5])
    assert outline.bottom_px == 200 + 29 - 0.5
