"""Hand-read truth of a real video: the ground point below a bumper's edge and the check of a record against it, the
hand count of vehicles through an image row and the measured tracks matched to it, and the highway clip's hand files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from vehloc.benchmark.crossings import (Crossing, CrossingCount, match_crossings, read_crossings, row_road_y_mm,
                                        track_crossing_frame)
from vehloc.benchmark.spot_truth import (Spot, SpotTruth, check_spot, front_mm, ground_point_mm, read_spot_truth,
                                         spot_table)
from vehloc.errors import DataError
from vehloc.geometry.calibration import CalibrationParams
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.keypoints import lowered_points_mm
from vehloc.geometry.pipeline.site_calibration import calibrate_site
from vehloc.geometry.pipeline.video import median_background
from vehloc.geometry.site import read_site

PROJECT = Path(__file__).resolve().parents[1]
REAL_VIDEO = PROJECT / "experiments" / "real_video"
# A camera over a road, as the highway clip's: 8.6 m high, 7 deg down, looking along +Y.
CAMERA = PinholeCamera.from_pose(np.array([2400.0, -46000.0, 8600.0]), 0.0, 7.0, 0.0, 1600.0, 320, 240)


def truth_of(*spots: Spot) -> SpotTruth:
    return SpotTruth(spots, {"car": 250.0, "suv": 400.0}, 80.0, 1.0)


def test_the_road_point_below_a_raised_point_is_exact() -> None:
    """A point 300 mm above the road at (1.5, 20) m, imaged and mapped to the road by the homography, lowered
    to that height, is (1.5, 20) m again; tolerance 1e-6 mm (floating point)."""
    point_mm = np.array([1500.0, 20000.0, 300.0])
    pixel = CAMERA.project(point_mm[None])[0]
    road_mm = CAMERA.image_to_road(pixel[None])
    assert np.linalg.norm(road_mm[0] - point_mm[:2]) > 500.0  # the homography alone puts it beyond
    np.testing.assert_allclose(lowered_points_mm(road_mm, 300.0, CAMERA.centre_mm)[0], point_mm[:2], atol=1e-6)
    np.testing.assert_allclose(ground_point_mm(tuple(pixel), 300.0, CAMERA), point_mm[:2], atol=1e-6)


def test_the_front_is_the_end_nearest_the_camera() -> None:
    """Of a 4.8 x 1.8 m footprint along the road, the middle of the end towards the camera's foot; exact."""
    corners = np.array([[-900.0, 10000.0], [900.0, 10000.0], [900.0, 14800.0], [-900.0, 14800.0]])
    np.testing.assert_allclose(front_mm(corners, CAMERA.centre_mm[:2]), [0.0, 10000.0], atol=1e-9)
    np.testing.assert_allclose(front_mm(corners[::-1], np.array([0.0, 90000.0])), [0.0, 14800.0], atol=1e-9)


def record_row(frame: int, box: tuple[int, int, int, int], status: str, corners_mm: np.ndarray | None) -> dict:
    row = {"track_id": 7, "frame": frame, "status": status, "reason_code": "poor_fit", "method": "fit",
           "box_x0_px": box[0], "box_y0_px": box[1], "box_x1_px": box[2], "box_y1_px": box[3]}
    for i in range(4):
        row[f"corner{i}_x_mm"] = np.nan if corners_mm is None else corners_mm[i, 0]
        row[f"corner{i}_y_mm"] = np.nan if corners_mm is None else corners_mm[i, 1]
    return row


@pytest.mark.parametrize("offset_mm, within", [(1000.0, True), (-2000.0, False)])
def test_a_record_is_checked_against_the_spot(offset_mm: float, within: bool) -> None:
    """A car's bumper edge 250 mm high at (0.5, 20) m read at its exact pixel; a record whose footprint's front lies
    `offset_mm` along the road from it: the error is that offset to 1e-6 mm, within 1.5 m or not."""
    edge_mm = np.array([500.0, 20000.0, 250.0])
    pixel = CAMERA.project(edge_mm[None])[0]
    spot = Spot(40, "right", "car", "white", (float(pixel[0]), float(pixel[1])))
    front_y = 20000.0 + offset_mm
    corners = np.array([[-400.0, front_y], [1400.0, front_y], [1400.0, front_y + 4800.0], [-400.0, front_y + 4800.0]])
    box = (int(pixel[0]) - 20, int(pixel[1]) - 30, int(pixel[0]) + 20, int(pixel[1]) + 3)
    records = pd.DataFrame([record_row(40, box, "localized", corners), record_row(41, box, "localized", corners)])
    check = check_spot(spot, truth_of(spot), records, CAMERA, 1500.0)
    np.testing.assert_allclose(check.truth_mm, edge_mm[:2], atol=1e-6)
    assert check.track_id == 7 and check.status == "localized"
    assert check.error_along_mm == pytest.approx(offset_mm, abs=1e-6)
    assert check.error_across_mm == pytest.approx(0.0, abs=1e-6)
    assert check.within is within
    assert check.truth_sigma_along_mm > 0
    assert spot_table([check]).within.tolist() == [within]


def test_a_spot_without_a_localized_record_fails_with_the_reason() -> None:
    """A record whose box holds the spot but is not localized gives its reason; a spot no box holds, `no record`."""
    spot = Spot(40, "left", "car", "red", (100.0, 120.0))
    records = pd.DataFrame([record_row(40, (80, 90, 130, 125), "not localized", None)])
    check = check_spot(spot, truth_of(spot), records, CAMERA, 1500.0)
    assert (check.status, check.reason, check.within) == ("not localized", "poor_fit", False)
    away = Spot(40, "left", "car", "red", (200.0, 120.0))
    assert check_spot(away, truth_of(away), records, CAMERA, 1500.0).status == "no record"


def test_a_bad_spot_file_is_one_line_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "spots.yaml"
    path.write_text("clearance_mm: {car: 220}\nclearance_sigma_mm: 80\nreading_sigma_px: 1\n"
                    "spots:\n  - {frame: 1, lane: middle, body: car, colour: red, front_x_px: 1, front_y_px: 2}\n")
    with pytest.raises(DataError, match=r"spots.yaml: spot 0 has lane 'middle'"):
        read_spot_truth(path)
    path.write_text("clearance_mm: {car: 220}\nclearance_sigma_mm: 80\nreading_sigma_px: 1\n"
                    "spots:\n  - {frame: 1, lane: left, body: van, colour: red, front_x_px: 1, front_y_px: 2}\n")
    with pytest.raises(DataError, match=r"spots.yaml: spot 0 has body 'van'"):
        read_spot_truth(path)


def test_the_highway_hand_spots_lie_in_their_lanes(shared_data: Path) -> None:
    """The hand file covers at least 12 frames, both lanes, near (front row >= 150 px) and far (<= 100 px); and with
    the clip's site calibration (as `highway.py` makes it) every spot's ground point lies on the road in the lane it
    was read in: left of the dashed line (X < 0) or right of it, and between the left curb's face (X about -3.1 m,
    measured) and the yellow line's outer edge (3.71 m); tolerance 0.1 m beyond the curb."""
    truth = read_spot_truth(REAL_VIDEO / "highway_spot_truth.yaml")
    rows = np.array([s.front_px[1] for s in truth.spots])
    assert len({s.frame for s in truth.spots}) >= 12
    for lane in ("left", "right"):
        assert (rows[[s.lane == lane for s in truth.spots]] >= 150).any()
        assert (rows[[s.lane == lane for s in truth.spots]] <= 100).any()
    video = shared_data / "traffic" / "highway_320x240.avi"
    background = median_background(video, 60)
    params = CalibrationParams.from_config(pinhole_model=True, refine_rounds=5,
                                           edge_search={"search_px": 3.0, "min_contrast": 25.0})
    site = calibrate_site(read_site(REAL_VIDEO / "highway_site.yaml"), background, "guess", params=params)
    calibration = site.camera_calibration("highway_site.yaml")
    for spot in truth.spots:
        x_mm = ground_point_mm(spot.front_px, truth.clearance_mm[spot.body], calibration.camera)[0]
        assert (x_mm < 0) == (spot.lane == "left"), (spot, x_mm)
        assert -3300.0 < x_mm < 3708.0, (spot, x_mm)


def test_a_tracks_crossing_of_a_row_is_where_its_front_reaches_the_rows_road_line() -> None:
    """A car 4.8 m long driving towards the camera at 25 m/s (1 m a frame at 25 fps), its centre at Y = 60 m at frame
    0: its front reaches the road line of image row 200 at the frame the exact geometry says; tolerance 1e-6 frame."""
    x_mm = 1500.0
    row_y_mm = row_road_y_mm(CAMERA.road_to_image(), 200.0, x_mm)
    assert CAMERA.project(np.array([[x_mm, row_y_mm, 0.0]]))[0, 1] == pytest.approx(200.0, abs=1e-6)
    frames = np.arange(10, 30)
    y_mm = 60000.0 - 1000.0 * frames
    expected = (60000.0 - 2400.0 - row_y_mm) / 1000.0
    assert track_crossing_frame(frames, y_mm, 4800.0, row_y_mm) == pytest.approx(expected, abs=1e-6)


def test_crossings_are_matched_one_to_one_in_their_lane() -> None:
    """Two hand crossings of the left lane 30 frames apart and one of the right: the measured track of each lane
    nearest in time takes each; a track of the wrong lane or too far in time takes none."""
    count = CrossingCount(200.0, 0, (Crossing(40, "left"), Crossing(70, "left"), Crossing(50, "right")))
    road_to_image = CAMERA.road_to_image()
    tracks, points = [], []

    def add(track_id: int, x_mm: float, crossing_frame: float) -> None:
        row_y = row_road_y_mm(road_to_image, 200.0, x_mm)
        frames = np.arange(int(crossing_frame) - 25, int(crossing_frame) - 5)
        y_mm = row_y + 2400.0 + 1000.0 * (crossing_frame - frames)  # its front at the row at crossing_frame
        tracks.append({"track_id": track_id, "status": "measured", "length_mm": 4800.0, "speed_kmh": 90.0})
        points.extend({"track_id": track_id, "frame": f, "x_mm": x_mm, "y_mm": y, "used": True}
                      for f, y in zip(frames, y_mm))

    add(1, -1800.0, 42.0)
    add(2, -1800.0, 66.0)
    add(3, 1800.0, 70.0)   # the right lane, 20 frames after its crossing: beyond 12
    matches = match_crossings(count, pd.DataFrame(tracks), pd.DataFrame(points), road_to_image,
                              lambda x: "left" if x < 0 else "right", 12.0)
    assert [m.track_id for m in matches] == [1, 2, None]
    assert matches[0].track_frame == pytest.approx(42.0, abs=1e-6)


def test_a_track_measured_by_its_box_bottom_crosses_where_its_path_does() -> None:
    """A truck of no known model: its path is its front's ground line already (`reference` box_bottom, no length),
    so it crosses where its points reach the row's road line; tolerance 1e-6 frame."""
    road_to_image = CAMERA.road_to_image()
    row_y = row_road_y_mm(road_to_image, 200.0, 1800.0)
    frames = np.arange(20, 40)
    tracks = pd.DataFrame([{"track_id": 7, "status": "measured", "length_mm": float("nan"), "speed_kmh": 90.0,
                            "reference": "box_bottom"}])
    points = pd.DataFrame([{"track_id": 7, "frame": f, "x_mm": 1800.0, "y_mm": row_y + 1000.0 * (45.0 - f),
                            "used": True} for f in frames])
    matches = match_crossings(CrossingCount(200.0, 0, (Crossing(45, "right"),)), tracks, points, road_to_image,
                              lambda x: "left" if x < 0 else "right", 12.0)
    assert matches[0].track_id == 7 and matches[0].track_frame == pytest.approx(45.0, abs=1e-6)


def test_a_vehicle_changing_lanes_is_matched_in_the_lane_it_crosses_in() -> None:
    """A track from the right lane (X 1.8 m) into the left (X -1.8 m), most of its points in the right, its front at
    the row at frame 45 in the left: the hand crossing of the left lane is its, the right lane's is not."""
    road_to_image = CAMERA.road_to_image()
    frames = np.arange(0, 50)
    x_mm = np.where(frames < 38, 1800.0, -1800.0)
    row_y = row_road_y_mm(road_to_image, 200.0, 1800.0)
    tracks = pd.DataFrame([{"track_id": 3, "status": "measured", "length_mm": 4800.0, "speed_kmh": 90.0}])
    points = pd.DataFrame([{"track_id": 3, "frame": f, "x_mm": x, "y_mm": row_y + 2400.0 + 1000.0 * (45.0 - f),
                            "used": True} for f, x in zip(frames, x_mm)])
    lane_of = lambda x: "left" if x < 0 else "right"  # noqa: E731
    for lane, matched in (("left", 3), ("right", None)):
        match = match_crossings(CrossingCount(200.0, 0, (Crossing(45, lane),)), tracks, points, road_to_image,
                                lane_of, 12.0)[0]
        assert match.track_id == matched


def test_the_highway_crossings_file_is_whole() -> None:
    """The hand count of the highway clip: its lanes left or right, its frames in the clip after its first frame and
    in order."""
    count = read_crossings(REAL_VIDEO / "highway_crossings.yaml")
    frames = [c.frame for c in count.crossings]
    assert len(frames) >= 20 and frames == sorted(frames)
    assert count.first_frame <= frames[0] and frames[-1] < 1699
    assert {c.lane for c in count.crossings} == {"left", "right"}
