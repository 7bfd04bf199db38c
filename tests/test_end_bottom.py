"""The end's bottom edge below a plate (`vehloc.geometry.end_bottom`): on drawn ROIs whose edge is known exactly, and
on rendered cars against the renderer's own coverage."""

from __future__ import annotations

import numpy as np
import pytest

from detector_scenes import BLACK, PLATE_POSES, RED_PICKUP, SILVER, WHITE, YELLOW_DARK_RIMS, render_case, road
from vehloc.config import ConfigError
from vehloc.geometry.end_bottom import end_bottom_px
from vehloc.geometry.footprint import FootprintParams
from vehloc.geometry.keypoints import DetectorParams
from vehloc.geometry.placement import direction_of
from vehloc.geometry.plate import plate_candidates

PARAMS = FootprintParams.from_config().end
ROAD_BGR = np.array([92.0, 95.0, 96.0])
BODIES_BGR = {"red paint": (30.0, 40.0, 150.0), "light grey": (110.0, 112.0, 113.0),
              "black paint": (8.0, 8.0, 7.0)}
VERTICAL = np.array([1.0, 0.0, -40.0])  # the image column x = 40
ACROSS = np.array([1.0, 0.0, 0.0])  # across lines along the image rows (their vanishing point at infinity)
EDGE_ROW = 30  # the body's last row: its bottom edge lies at y = 30.5
PLATE_BOTTOM = np.array([40.0, 20.5])


def drawn_end(body_bgr: tuple[float, float, float], shade: bool, noise: float = 1.5,
              seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An 80 x 60 ROI: the end's paint down to row `EDGE_ROW`, below it the road, darkened at the body to 0.28 of its
    light and lighter row by row further out when `shade` (as the shadow under a car), else lit; its light ratio
    and silhouette (the body and the shade)."""
    rng = np.random.default_rng(seed)
    rows = np.arange(60)[:, None]
    below = np.clip(rows - EDGE_ROW - 1, 0, None)
    ratio = np.where(rows > EDGE_ROW, np.minimum(1.0, 0.28 * np.exp(0.09 * below)) if shade else 1.0, 1.0)
    road = ROAD_BGR * (1.0 + 0.05 * rng.standard_normal((60, 80, 1)))
    frame = np.where((rows <= EDGE_ROW)[..., None], np.array(body_bgr), road * ratio[..., None])
    frame = np.clip(frame + noise * rng.standard_normal(frame.shape), 0, 255)
    light_ratio = (frame.sum(axis=2) + 1.0) / (road.sum(axis=2) + 1.0)
    mask = (rows <= EDGE_ROW) | (ratio < 0.9)
    return frame.astype(np.uint8), light_ratio, np.broadcast_to(mask, (60, 80)).copy()


@pytest.mark.parametrize("body", list(BODIES_BGR))
@pytest.mark.parametrize("shade", [True, False], ids=["shade below", "lit road below"])
def test_the_end_meets_the_road_where_it_was_drawn(body: str, shade: bool) -> None:
    """Coloured, light grey and black paint over the car's shade or over lit road: the edge on the vertical through
    P is the drawn one, exactly (the profile steps whole pixels, the edge lies between two of them)."""
    frame, light_ratio, mask = drawn_end(BODIES_BGR[body], shade)
    found = end_bottom_px(frame, light_ratio, mask, np.zeros(2), PLATE_BOTTOM, VERTICAL, ACROSS, 10.0, PARAMS)
    assert found is not None
    np.testing.assert_allclose(found, [40.0, EDGE_ROW + 0.5], atol=1e-9)


def test_the_roi_offset_and_a_tilted_end_are_followed() -> None:
    """The same end drawn with its edge sloping 0.1 px a column (the across lines through a vanishing point 400 px to
    the right), in an ROI whose top-left lies at (100, 200) in the frame: the crossing with the vertical within half a
    pixel of the drawn one."""
    rng = np.random.default_rng(3)
    rows, columns = np.mgrid[0:60, 0:80].astype(float)
    vanishing = np.array([440.0, 30.5 - 0.1 * 400.0, 1.0])  # the edge line y = 30.5 + 0.1 (x - 40) seen from x = 440
    edge_y = 30.5 + 0.1 * (columns - 40.0)
    body = rows + 0.5 <= edge_y
    ratio = np.where(body, 1.0, np.minimum(1.0, 0.28 * np.exp(0.09 * np.clip(rows - edge_y, 0, None))))
    road = ROAD_BGR * (1.0 + 0.05 * rng.standard_normal((60, 80, 1)))
    frame = np.where(body[..., None], np.array(BODIES_BGR["red paint"]), road * ratio[..., None]).astype(np.uint8)
    light_ratio = (frame.sum(axis=2) + 1.0) / (road.sum(axis=2) + 1.0)
    offset = np.array([100.0, 200.0])
    frame_vertical = np.array([1.0, 0.0, -140.0])
    frame_vanishing = vanishing + [100.0, 200.0, 0.0]
    found = end_bottom_px(frame, light_ratio, body | (ratio < 0.9), offset, PLATE_BOTTOM + offset, frame_vertical,
                          frame_vanishing, 10.0, PARAMS)
    assert found is not None
    assert found[0] == pytest.approx(140.0)
    assert abs(found[1] - (200.0 + 30.5)) <= 0.5


def test_no_edge_is_read_where_the_silhouette_ends_at_the_plate() -> None:
    """A silhouette that stops above the plate's lower edge has no end below the plate to read."""
    frame, light_ratio, mask = drawn_end(BODIES_BGR["red paint"], True)
    mask[19:] = False
    assert end_bottom_px(frame, light_ratio, mask, np.zeros(2), PLATE_BOTTOM, VERTICAL, ACROSS, 10.0, PARAMS) is None


@pytest.mark.parametrize("car", [SILVER, BLACK, WHITE, RED_PICKUP, YELLOW_DARK_RIMS])
@pytest.mark.parametrize("pose", list(PLATE_POSES))
def test_a_rendered_ends_bottom_within_a_pixel_of_the_renderers(car, pose) -> None:
    """Rendered cars, front or rear towards the Table 2 camera 4-10 m away, the plate found by the detector and the
    end's across direction the true one: the edge lies 0 to 1 px below the renderer's coverage bottom in its column
    (the last pixel the car covers at least half of, itself within half a pixel of the true edge); the pixel the car
    covers less than half of still reads as paint."""
    case = render_case(car, pose)
    camera = case.camera
    road_to_image = camera.road_to_image()
    x0, y0 = case.offset_px.astype(int)
    height, width = case.mask.shape
    background = road(0)[y0:y0 + height, x0:x0 + width].astype(float)
    light_ratio = (case.roi_bgr.astype(float).sum(axis=2) + 1.0) / (background.sum(axis=2) + 1.0)
    plate = plate_candidates(case.roi_bgr, case.mask, case.offset_px, DetectorParams.from_config().plate)[0]
    vertical = np.cross([*plate.centre_px, 1.0], road_to_image.homogeneous(camera.centre_mm[:2])[0])
    plate_bottom = np.cross(vertical, plate.lower_line_px)
    across = direction_of(case.pose.heading_deg + 90.0)
    vanishing = road_to_image.front_sign * (road_to_image.matrix @ [across[0], across[1], 0.0])
    width_px = float(np.linalg.norm(plate.corners_px[1] - plate.corners_px[0]))
    found = end_bottom_px(case.roi_bgr, light_ratio, case.mask, case.offset_px, plate_bottom[:2] / plate_bottom[2],
                          vertical, vanishing, width_px, PARAMS)
    assert found is not None
    column = int(round(found[0])) - x0
    covered_bottom = np.flatnonzero(case.mask[:, column]).max() + 0.5 + y0
    assert 0.0 <= found[1] - covered_bottom <= 1.0 + 1e-6


@pytest.mark.parametrize("setting, value", [("span_plate_widths", 0.0), ("road_margin_px", 0), ("max_rise", -0.1)])
def test_an_end_setting_out_of_range_is_named(setting: str, value: float) -> None:
    with pytest.raises(ConfigError, match=f"footprint.end.{setting}"):
        FootprintParams.from_config(end={setting: value})

