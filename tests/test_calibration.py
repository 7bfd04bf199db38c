"""Lane-marker detection and calibration on rendered roads, whose homography is known exactly."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from vehloc.geometry.calibration import (
    CalibrationError,
    CalibrationParams,
    calibrate,
    camera_from_homography,
    refine_on_site,
)
from vehloc.geometry.edges import stripe_edges
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.markers import detect_markers
from vehloc.geometry.site import Site, SiteError, SiteMarker, homography_from_points, read_site, site_yaml
from vehloc.atomic import write_text
from vehloc.synth.road import RoadLayout, render_road

CAMERAS = {
    "side_high": PinholeCamera.look_at([2500, -8000, 6500], [0, 9000, 0], 1100, 1280, 720),
    "centre_low_rolled": PinholeCamera.look_at([-1000, -6000, 4500], [500, 10000, 0], 950, 1280, 720, roll_deg=2.0),
}
LAYOUT = RoadLayout(lane_count=3, stop_line_y_mm=14000, start_y_mm=-2000, end_y_mm=60000)


def _true_homography(camera: PinholeCamera) -> np.ndarray:
    return camera.road_to_image().normalised_matrix


def _site_with_clicked_guess(camera: PinholeCamera, click_noise_px: float, seed: int) -> Site:
    """Surveyed corners of the layout, and four well-spread corners 'clicked' with pixel noise."""
    markers = tuple(SiteMarker(m.marker_id, m.corners_mm) for m in LAYOUT.markers() if m.has_corners)
    by_id = {m.marker_id: m.corners_mm for m in markers}
    clicked_world = np.array(
        [by_id["lane1_dash1"][0], by_id["lane2_dash1"][1], by_id["lane2_dash3"][2], by_id["lane1_dash3"][3]]
    )
    rng = np.random.default_rng(seed)
    clicked_px = camera.project(np.column_stack([clicked_world, np.zeros(4)])) + rng.normal(0, click_noise_px, (4, 2))
    points = tuple((tuple(w), tuple(p)) for w, p in zip(clicked_world, clicked_px))
    guess = homography_from_points(clicked_world, clicked_px, "test")
    return Site("rendered", markers, guess / guess[2, 2], (1280, 720), points)


def _visible_world_corners(camera: PinholeCamera, site: Site) -> np.ndarray:
    world, _ = site.world_corners_mm()
    pixels = camera.project(np.column_stack([world, np.zeros(len(world))]))
    inside = np.all(np.isfinite(pixels), axis=1) & (pixels[:, 0] >= 0) & (pixels[:, 0] < 1280)
    inside &= (pixels[:, 1] >= 0) & (pixels[:, 1] < 720)
    return world[inside]


@pytest.fixture(scope="module", params=sorted(CAMERAS))
def rendered(request: pytest.FixtureRequest) -> tuple[PinholeCamera, np.ndarray]:
    camera = CAMERAS[request.param]
    return camera, render_road(camera, LAYOUT, np.random.default_rng(3))


def test_marker_edges_are_sub_pixel(rendered: tuple[PinholeCamera, np.ndarray]) -> None:
    """Tolerance: median distance of edge points to the true image of their side <= 0.2 px."""
    camera, image = rendered
    markers = detect_markers(image)
    assert len(markers) >= 8
    lines = []
    for marker in LAYOUT.markers():
        for k in range(4):
            world_line = np.cross([*marker.corners_mm[k], 1.0], [*marker.corners_mm[(k + 1) % 4], 1.0])
            lines.append(world_line @ np.linalg.inv(_true_homography(camera)))
    lines = np.array(lines)
    distances = []
    for marker in markers:
        for points in marker.side_points_px:
            homogeneous = np.column_stack([points, np.ones(len(points))])
            d = np.abs(homogeneous @ lines.T) / np.hypot(lines[:, 0], lines[:, 1])
            distances += list(d.min(axis=1))
    assert np.median(distances) <= 0.2


@pytest.mark.parametrize("click_noise_px", [0.0, 4.0])
def test_calibration_recovers_the_true_homography(
    rendered: tuple[PinholeCamera, np.ndarray], click_noise_px: float
) -> None:
    """Tolerances (issue): RMS <= 1 px over every surveyed corner inside the image; image -> road
    within 1 % of each point's distance from the camera."""
    camera, image = rendered
    site = _site_with_clicked_guess(camera, click_noise_px, seed=1)
    calibration = calibrate(detect_markers(image), site)
    assert calibration.inlier_count >= 16
    world = _visible_world_corners(camera, site)
    error_px = calibration.road_to_image(world) - camera.road_to_image()(world)
    assert np.sqrt(np.mean(np.sum(error_px**2, axis=1))) <= 1.0

    grid_px = np.stack(np.meshgrid(np.arange(100, 1200, 100), np.arange(420, 720, 60)), -1).reshape(-1, 2)
    true_road = camera.image_to_road(grid_px)
    on_road = np.abs(true_road[:, 0]) <= LAYOUT.road_width_mm / 2
    distance_mm = np.linalg.norm(np.column_stack([true_road, np.zeros(len(true_road))]) - camera.centre_mm, axis=1)
    road_error_mm = np.linalg.norm(calibration.image_to_road(grid_px) - true_road, axis=1)
    assert on_road.sum() > 10
    assert np.all(road_error_mm[on_road] <= 0.01 * distance_mm[on_road])


def test_camera_from_exact_homography() -> None:
    camera = CAMERAS["centre_low_rolled"]
    recovered = camera_from_homography(camera.road_to_image(), 1280, 720)
    assert recovered.focal_px == pytest.approx(950, abs=1e-6)
    np.testing.assert_allclose(recovered.camera.centre_mm, camera.centre_mm, atol=1e-6)
    np.testing.assert_allclose(recovered.camera.R, camera.R, atol=1e-9)
    assert recovered.height_mm == pytest.approx(4500, abs=1e-6)


def test_camera_from_calibrated_homography(rendered: tuple[PinholeCamera, np.ndarray]) -> None:
    """Tolerance: focal and height within 2 %, tilt within 0.5 deg of the rendering camera's."""
    camera, image = rendered
    calibration = calibrate(detect_markers(image), _site_with_clicked_guess(camera, 2.0, seed=2))
    recovered = camera_from_homography(calibration.transform, 1280, 720)
    true_tilt_deg = np.degrees(np.arcsin(-camera.R[2, 2]))
    assert recovered.focal_px == pytest.approx(camera.focal_px, rel=0.02)
    assert recovered.height_mm == pytest.approx(camera.centre_mm[2], rel=0.02)
    assert recovered.tilt_deg == pytest.approx(true_tilt_deg, abs=0.5)


def test_no_markers_is_a_clear_error() -> None:
    camera = CAMERAS["side_high"]
    site = _site_with_clicked_guess(camera, 0.0, seed=0)
    blank = np.full((720, 1280, 3), 90, np.uint8)
    with pytest.raises(CalibrationError, match="only 0 detected marker corner"):
        calibrate(detect_markers(blank), site)


def test_site_round_trip(tmp_path: Path) -> None:
    site = _site_with_clicked_guess(CAMERAS["side_high"], 1.0, seed=0)
    write_text(tmp_path / "site.yaml", site_yaml(site))
    again = read_site(tmp_path / "site.yaml")
    assert [m.marker_id for m in again.markers] == [m.marker_id for m in site.markers]
    np.testing.assert_allclose(again.initial_homography, site.initial_homography, rtol=1e-6, atol=1e-9)
    assert again.image_size_px == (1280, 720)


MARKERS_YAML = "markers:\n  - id: a\n    corners_mm: [[0, 0], [150, 0], [150, 3000], [0, 3000]]\n"


@pytest.mark.parametrize(
    ("guess", "message"),
    [
        ("initial_guess:\n  points:\n" + "".join(f"    - {{world_mm: [{x}, {y}], image_px: [{x}, {y}]}}\n" for x, y in [(0, 0), (1, 0), (0, 1)]),
         "3 point\\(s\\) given, a homography needs at least 4"),
        ("initial_guess:\n  points:\n" + "".join(f"    - {{world_mm: [{x}, {x}], image_px: [{x}, {y}]}}\n" for x, y in [(0, 0), (1, 5), (2, 1), (3, 9)]),
         "the world points are collinear"),
        ("initial_guess: {}\n", "needs 'points' \\(at least 4\\) or 'homography'"),
        ("initial_guess:\n  homography: [[1, 0], [0, 1]]\n", "invertible 3x3"),
    ],
)
def test_bad_site_files(tmp_path: Path, guess: str, message: str) -> None:
    path = tmp_path / "site.yaml"
    path.write_text(MARKERS_YAML + guess)
    with pytest.raises(SiteError, match=message):
        read_site(path)


def test_site_file_missing_or_not_yaml(tmp_path: Path) -> None:
    with pytest.raises(SiteError, match="site file does not exist"):
        read_site(tmp_path / "none.yaml")
    (tmp_path / "bad.yaml").write_text("markers: [unclosed\n")
    with pytest.raises(SiteError, match="not valid YAML"):
        read_site(tmp_path / "bad.yaml")


def test_stripe_edges_are_sub_pixel() -> None:
    """Edge points found across a solid edge line lie within 0.25 px (median) of its true edges."""
    camera = CAMERAS["side_high"]
    image = render_road(camera, LAYOUT, np.random.default_rng(3))
    grey = image.mean(axis=2).astype(np.float32)
    edge = next(m for m in LAYOUT.markers() if m.marker_id == "edge_right")
    start, end = edge.corners_mm[:2].mean(0), edge.corners_mm[2:].mean(0)
    rough = _site_with_clicked_guess(camera, 3.0, seed=4).initial_transform()
    edges = stripe_edges(grey, rough, start, end, 150.0, CalibrationParams.from_config().edge_search)
    assert len(edges) == 2
    truth_inverse = np.linalg.inv(_true_homography(camera))
    for world_line, points in edges:
        image_line = world_line @ truth_inverse
        distance = np.abs(np.column_stack([points, np.ones(len(points))]) @ image_line) / np.hypot(*image_line[:2])
        assert len(points) >= 20 and np.median(distance) <= 0.25


def test_refinement_from_the_rough_guess_alone() -> None:
    """Searching the site's predicted edges around a 3 px rough guess recovers H: RMS <= 1 px."""
    camera = CAMERAS["side_high"]
    image = render_road(camera, LAYOUT, np.random.default_rng(3))
    site = _site_with_clicked_guess(camera, 3.0, seed=4)
    road_to_image, median_edge_px = refine_on_site(image, site, site.initial_transform())
    world = _visible_world_corners(camera, site)
    error_px = road_to_image(world) - camera.road_to_image()(world)
    assert np.sqrt(np.mean(np.sum(error_px**2, axis=1))) <= 1.0 and median_edge_px < 0.3


def _calibration_file(tmp_path: Path, homography: np.ndarray, rms: object = 0.4) -> Path:
    path = tmp_path / "calibration.json"
    path.write_text(json.dumps({"homography_world_mm_to_image_px": np.asarray(homography).tolist(),
                                "image_size_px": [1280, 720], "rms_reprojection_px": rms}))
    return path


@pytest.mark.parametrize(("defect", "message"), [
    ("rms_nan", "rms_reprojection_px must be a finite number >= 0, got nan"),
    ("rms_negative", "rms_reprojection_px must be a finite number >= 0, got -1.0"),
    ("singular", "the homography is singular (rank 2)"),
    ("horizon_in_the_road", "the road's horizon crosses the image's bottom row"),
])
def test_a_calibration_file_is_checked_on_read(defect: str, message: str, tmp_path: Path) -> None:
    """A calibration whose RMS is NaN or negative fed NaN sigmas into every position; a singular homography or one
    whose horizon cuts through the road nearest the camera is no camera's view of a road: each is refused on read."""
    good = _true_homography(CAMERAS["side_high"])
    assert read_calibration(_calibration_file(tmp_path, good)).camera is not None
    homography, rms = good.copy(), 0.4
    if defect.startswith("rms"):
        rms = float("nan") if defect == "rms_nan" else -1.0
    elif defect == "singular":
        homography[2] = homography[0] + homography[1]
    else:  # the image turned a quarter about its centre: the horizon, above the image, now stands upright in it
        quarter_turn = np.array([[0.0, -1.0, 640.0 + 360.0], [1.0, 0.0, 360.0 - 640.0], [0.0, 0.0, 1.0]])
        homography = quarter_turn @ homography
    with pytest.raises(CalibrationError, match=re.escape(message)):
        read_calibration(_calibration_file(tmp_path, homography, rms))


def test_a_guess_on_an_image_without_the_sites_markers_is_no_calibration() -> None:
    """mode=guess on a frame where no marker shows reported 'RMS 0.00 px' (the clicked points against themselves)
    and replaced a good calibration; with no edge to refine on it is refused."""
    from vehloc.geometry.calibration import calibrate_from_guess

    site = _site_with_clicked_guess(CAMERAS["side_high"], 3.0, seed=4)
    plain_road = np.full((720, 1280, 3), 96, np.uint8)
    with pytest.raises(CalibrationError, match="no edge of its markers or stripes is where the clicked guess puts them"):
        calibrate_from_guess(plain_road, site)
