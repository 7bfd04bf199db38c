"""Level lines across a vehicle's end: their road direction against exact geometry, the end's lower outline read as
one on drawn masks, and on rendered ends with small plates against the true heading."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from detector_scenes import (BLACK, RED_PICKUP, SILVER, SMALL_PLATE_POSES, WHITE, WHITE_SMALL,
                             YELLOW_DARK_RIMS, heading_error_deg, render_case, site)
from vehloc.config import ConfigError, build_params
from vehloc.geometry.keypoints import plate_width_heading_deg
from vehloc.geometry.level_lines import (EndLineParams, end_line, end_line_heading_deg, level_lines_direction_deg,
                                         robust_line)
from vehloc.geometry.plate import PlateParams, detect_plate

PARAMS = PlateParams.from_config().end_line
FAR_END_POSES = ["far_front_20", "far_rear_20", "far_rear_30"]


def level_line_image(direction_deg: float, through_mm: tuple[float, float], height_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Two image points (2, 2) px of a level 3D line `height_mm` above the road through `through_mm` along
    `direction_deg`, seen by the Table 2 camera, and the line through them (homogeneous)."""
    camera = site()[0]
    along = np.array([np.cos(np.radians(direction_deg)), np.sin(np.radians(direction_deg))])
    ends = np.array([[*(np.asarray(through_mm) + s * 900.0 * along), height_mm] for s in (-1.0, 1.0)])
    points = camera.project(ends)
    return points, np.cross([*points[0], 1.0], [*points[1], 1.0])


def mask_below(points_px: np.ndarray, shape: tuple[int, int], offset_px: np.ndarray, bend_px: float = 0.0) -> np.ndarray:
    """A silhouette whose columns end at the image line through `points_px` (each column's pixels with their middle
    above it), bent down by `bend_px` per column from the middle outwards (a V)."""
    (x0, y0), (x1, y1) = points_px - offset_px
    columns = np.arange(shape[1]) + 0.5
    bottom = y0 + (y1 - y0) * (columns - x0) / (x1 - x0) + bend_px * np.abs(columns - shape[1] / 2)
    rows = np.arange(shape[0])[:, None] + 0.5
    return rows <= bottom[None, :]


@pytest.mark.parametrize("direction_deg", [0.0, 8.0, 30.0, 95.0, 172.0])
@pytest.mark.parametrize("height_mm", [0.0, 350.0, 1200.0])
def test_a_level_line_maps_to_its_road_direction_at_any_height(direction_deg, height_mm):
    """The inverse homography keeps a level line's direction (1e-6 deg) whatever its height."""
    _, line = level_line_image(direction_deg, (500.0, 12000.0), height_mm)
    assert heading_error_deg(level_lines_direction_deg(line[None], site()[0].road_to_image()), direction_deg) < 1e-6


def test_robust_line_cuts_the_outliers_and_keeps_the_line():
    """Forty points exactly on y = 3 + 0.1 x and five 6-9 px below it (a wheel): the line exactly (1e-9), the five cut."""
    x = np.arange(45.0)
    y = 3.0 + 0.1 * x
    y[[2, 11, 20, 33, 44]] += [6.0, 7.0, 9.0, 8.0, 6.5]
    slope, intercept, kept = robust_line(np.column_stack([x, y]), 2.5)
    assert slope == pytest.approx(0.1, abs=1e-9)
    assert intercept == pytest.approx(3.0, abs=1e-9)
    assert np.flatnonzero(~kept).tolist() == [2, 11, 20, 33, 44]


@pytest.mark.parametrize(("direction_deg", "distance_mm", "trusted"), [
    (6.0, 22000.0, True), (10.0, 22000.0, True), (174.0, 22000.0, True), (4.0, 12000.0, True),
    (0.0, 22000.0, False), (2.0, 22000.0, False), (178.0, 22000.0, False),
])
def test_an_end_outline_gives_the_across_direction_within_its_sigma(direction_deg, distance_mm, trusted):
    """A silhouette ending on the image of a level line 300 mm high across a car 12 or 22 m away (about 100 or 60 px
    wide here): its across direction within 2 sigma of the truth (measured: 1.02 sigma at most). Sigma is under the
    1 deg asked where the outline changes rows often enough (6 deg or more off the image rows at 22 m); a line within
    one or two rows (0-2 deg there, a rise of half a pixel) is known only to a pixel over its span (2.5 deg)."""
    points, _ = level_line_image(direction_deg, (300.0, distance_mm), 300.0)
    offset = np.floor(points.min(axis=0)) - [4.0, 30.0]
    shape = (int(np.ceil(points[:, 1].max() - offset[1])) + 10, int(np.ceil(points[:, 0].max() - offset[0])) + 4)
    mask = mask_below(points, shape, offset)
    centre = offset + [shape[1] / 2, 20.0]
    line = end_line(mask, offset, centre, 20.0 if distance_mm > 15000.0 else 40.0, site()[0].road_to_image(), PARAMS)
    assert line is not None
    assert heading_error_deg(line.across_deg, direction_deg) <= 2.0 * line.sigma_deg
    assert (line.sigma_deg <= PARAMS.max_sigma_deg) == trusted


def plate_corners_along(points_px: np.ndarray, centre_px: np.ndarray, width_px: float, turn_deg: float) -> np.ndarray:
    """A plate's corners (ordered) `width_px` wide and a third as tall about `centre_px`, its long sides along the
    line through `points_px` turned by `turn_deg` in the image."""
    along = points_px[1] - points_px[0]
    angle = np.arctan2(along[1], along[0]) + np.radians(turn_deg)
    u = np.array([np.cos(angle), np.sin(angle)]) * width_px / 2
    v = np.array([-u[1], u[0]]) / 3
    return centre_px + np.array([-u - v, u - v, u + v, -u + v])


@pytest.mark.parametrize(("what", "bend_px", "turn_deg", "enabled", "used"), [
    ("a straight outline, the plate along it", 0.0, 0.0, True, True),
    ("the plate turned within a pixel over its width (2.5 deg at 20 px)", 0.0, 2.5, True, True),
    ("the plate turned by 4 deg: more than a pixel", 0.0, 4.0, True, False),
    ("a bent outline (a V of 0.4 px a column)", 0.4, 0.0, True, False),
    ("off", 0.0, 0.0, False, False),
])
def test_the_end_line_sets_the_heading_only_where_it_is_a_line_the_plate_agrees_with(what, bend_px, turn_deg,
                                                                                      enabled, used):
    points, _ = level_line_image(8.0, (300.0, 22000.0), 300.0)
    offset = np.floor(points.min(axis=0)) - [4.0, 30.0]
    shape = (int(np.ceil(points[:, 1].max() - offset[1])) + 40, int(np.ceil(points[:, 0].max() - offset[0])) + 4)
    mask = mask_below(points, shape, offset, bend_px)
    centre = offset + [shape[1] / 2, 20.0]
    params = dataclasses.replace(PARAMS, enabled=enabled)
    heading = end_line_heading_deg(mask, offset, plate_corners_along(points, centre, 20.0, turn_deg), centre,
                                   site()[0].road_to_image(), params)
    assert (heading is not None) == used
    if used:
        assert heading_error_deg(heading, 98.0) < 1.0


@pytest.mark.parametrize(("setting", "value"), [("half_span_plate_widths", 0.0), ("trim_deviations", -1.0),
                                                 ("max_sigma_deg", 0.0), ("plate_agreement_px", -0.5)])
def test_bad_settings_are_refused(setting, value):
    values = dataclasses.asdict(PARAMS) | {setting: value}
    with pytest.raises(ConfigError, match=setting):
        build_params(EndLineParams, values, "plate.end_line")


def test_rendered_small_plates_end_line_heading():
    """Six cars at the small-plate poses (19-24 m, plates 11-18 px wide) and 10 m away: wherever a small plate is found
    and its end line is used, that heading is within 5 deg of the truth (measured: 4.8 deg at most, on fronts, whose
    lower outline is not quite level; 0.5 deg on rears) and no further off than the plate's own edges or within
    0.5 deg; it is used on at least 12 of the 28 small plates (measured: 16)."""
    used = 0
    for car in (SILVER, BLACK, WHITE, YELLOW_DARK_RIMS, RED_PICKUP, WHITE_SMALL):
        for pose in [*SMALL_PLATE_POSES, *FAR_END_POSES]:
            case = render_case(car, pose)
            plate = detect_plate(case.roi_bgr, case.mask, case.offset_px, PlateParams.from_config())
            if plate is None or not plate.small:
                continue
            road_to_image = case.camera.road_to_image()
            heading = end_line_heading_deg(case.mask, case.offset_px, plate.corners_px, plate.centre_px,
                                           road_to_image, PARAMS)
            if heading is None:
                continue
            used += 1
            error = heading_error_deg(heading, case.pose.heading_deg)
            plate_error = heading_error_deg(plate_width_heading_deg(plate, road_to_image) + 90.0, case.pose.heading_deg)
            assert error <= 5.0, (car, pose)
            assert error <= plate_error or error <= 0.5, (car, pose)
    assert used >= 12
