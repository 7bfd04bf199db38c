"""The rear lamps either side of a plate: drawn ends with exact middles, and rendered rear views against the true
heading."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from detector_scenes import BLACK, RED_PICKUP, SILVER, WHITE_SMALL, YELLOW_DARK_RIMS, render_case
from vehloc.config import ConfigError, build_params
from vehloc.geometry.keypoints import plate_width_heading_deg, rear_lamps_heading_deg
from vehloc.geometry.lamps import LampParams, rear_lamps
from vehloc.geometry.plate import PlateParams, detect_plate

PARAMS = PlateParams.from_config().rear_lamps
RED_BGR, GREY_BGR = (30, 24, 200), (150, 150, 150)
REAR_POSES = ["near_rear", "far_rear_20", "far_rear_30", "small_rear_24", "small_rear_quarter_60",
              "small_rear_quarter_120"]


def drawn_end(body_bgr=GREY_BGR, left=(10, 20, 24, 30), right=(70, 20, 84, 30)) -> np.ndarray:
    """A 100 x 50 px end painted `body_bgr` with two red lamps (x0, y0, x1, y1 of each, exclusive ends)."""
    image = np.zeros((50, 100, 3), np.uint8)
    image[:] = body_bgr
    for x0, y0, x1, y1 in (left, right):
        image[y0:y1, x0:x1] = RED_BGR
    return image


def heading_error_deg(a_deg: float, b_deg: float) -> float:
    return abs((a_deg - b_deg + 90.0) % 180.0 - 90.0)


def test_two_red_lamps_either_side_give_the_line_through_their_middles():
    """Lamps drawn 14 x 10 px and 14 x 10 px either side of the middle, one 3 px lower: their middles exactly
    (1e-9 px), in frame px (the ROI's offset added), left first; the line through both."""
    image = drawn_end(right=(70, 23, 84, 33))
    offset = np.array([200.0, 100.0])
    pair = rear_lamps(image, np.ones(image.shape[:2], bool), offset, offset + [50.0, 25.0], PARAMS)
    assert pair is not None
    np.testing.assert_allclose(pair.centres_px, [[216.5, 124.5], [276.5, 127.5]], atol=1e-9)
    np.testing.assert_allclose(pair.line_px[:2] @ pair.centres_px.T + pair.line_px[2], 0.0, atol=1e-9)
    assert np.hypot(*pair.line_px[:2]) == pytest.approx(1.0)


@pytest.mark.parametrize(("what", "image", "between_x"), [
    ("a red body joins its lamps", drawn_end(body_bgr=RED_BGR), 50.0),
    ("no lamp right of the plate", drawn_end(right=(10, 35, 24, 45)), 50.0),
    ("lamps unlike in size (14 x 10 against 4 x 4)", drawn_end(right=(70, 20, 74, 24)), 50.0),
    ("both lamps left of the plate", drawn_end(), 90.0),
])
def test_no_pair(what, image, between_x):
    assert rear_lamps(image, np.ones(image.shape[:2], bool), np.zeros(2), np.array([between_x, 25.0]), PARAMS) is None


def test_lamps_outside_the_silhouette_are_not_seen():
    image = drawn_end()
    mask = np.ones(image.shape[:2], bool)
    mask[:, 60:] = False
    assert rear_lamps(image, mask, np.zeros(2), np.array([50.0, 25.0]), PARAMS) is None


@pytest.mark.parametrize("car", [SILVER, BLACK, YELLOW_DARK_RIMS, WHITE_SMALL])
@pytest.mark.parametrize("pose", REAR_POSES)
def test_rendered_rear_lamps_give_the_heading(car, pose):
    """Rear views 4-24 m away, end-on and 30-60 deg off it (plates 15-47 px wide): the lamps' heading within 2 deg of
    the truth (measured: 1.7 deg at most); where the plate's own edges are more than 5 deg off (small plates), the
    lamps are nearer every time."""
    case = render_case(car, pose)
    plate = detect_plate(case.roi_bgr, case.mask, case.offset_px, PlateParams.from_config())
    assert plate is not None
    road_to_image = case.camera.road_to_image()
    heading = rear_lamps_heading_deg(plate, case.roi_bgr, case.mask, case.offset_px, road_to_image, PARAMS, None)
    assert heading is not None
    assert heading_error_deg(heading, case.pose.heading_deg) <= 2.0
    plate_error = heading_error_deg(plate_width_heading_deg(plate, road_to_image) + 90.0, case.pose.heading_deg)
    assert plate_error <= 5.0 or heading_error_deg(heading, case.pose.heading_deg) < plate_error


@pytest.mark.parametrize("pose", ["near_rear", "small_rear_quarter_60"])
def test_a_red_body_gives_no_lamps(pose):
    """The red pickup's lamps are one part with its body: no pair, and the plate's rule stands."""
    case = render_case(RED_PICKUP, pose)
    plate = detect_plate(case.roi_bgr, case.mask, case.offset_px, PlateParams.from_config())
    assert plate is not None
    assert rear_lamps(case.roi_bgr, case.mask, case.offset_px, plate.centre_px, PARAMS) is None


def test_a_front_in_view_or_the_setting_off_asks_for_no_lamps():
    case = render_case(SILVER, "near_rear")
    plate = detect_plate(case.roi_bgr, case.mask, case.offset_px, PlateParams.from_config())
    road_to_image = case.camera.road_to_image()
    args = (plate, case.roi_bgr, case.mask, case.offset_px, road_to_image)
    assert rear_lamps_heading_deg(*args, PARAMS, "rear") is not None
    assert rear_lamps_heading_deg(*args, PARAMS, "front") is None
    assert rear_lamps_heading_deg(*args, dataclasses.replace(PARAMS, enabled=False), "rear") is None


@pytest.mark.parametrize(("change", "named"), [
    ({"hue_ranges": [[20, 10]]}, "plate.rear_lamps.hue_ranges[0]"),
    ({"hue_ranges": []}, "plate.rear_lamps.hue_ranges"),
    ({"max_area_ratio": 0.5}, "plate.rear_lamps.max_area_ratio"),
    ({"min_area_px": 0}, "plate.rear_lamps.min_area_px"),
    ({"max_off_middle": 0.6}, "plate.rear_lamps.max_off_middle"),
])
def test_a_bad_setting_is_named(change, named):
    values = {**dataclasses.asdict(PARAMS), **change}
    with pytest.raises(ConfigError, match=named.replace(".", r"\.").replace("[", r"\[").replace("]", r"\]")):
        build_params(LampParams, values, "plate.rear_lamps")


def test_a_pair_the_plate_does_not_stand_between_is_no_pair():
    """The lamps' midpoint at x 46.5: the plate's middle at 50 is 0.06 of their 60 px apart from it, at 60 it is 0.23,
    beyond `max_off_middle` (0.2)."""
    image = drawn_end()
    mask = np.ones(image.shape[:2], bool)
    assert rear_lamps(image, mask, np.zeros(2), np.array([50.0, 25.0]), PARAMS) is not None
    assert rear_lamps(image, mask, np.zeros(2), np.array([60.0, 25.0]), PARAMS) is None
