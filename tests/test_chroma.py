"""A shadow keeps the road's chromaticity, paint does not; beside a saturated car coded as video (colour at half
resolution), its shadow keeps it once the bleed is allowed for, against the renderer's exact shadow and coverage."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vehloc.config import ConfigError
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.chroma import chroma, chromaticity_shift, colour_change
from vehloc.geometry.roi import RoiParams, vehicle_silhouette
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import CarPose, Lighting, render_car, shadow_darkening

CAMERA = PinholeCamera.look_at([6000.0, 0.0, 5000.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)
POSE = CarPose(-500.0, 15000.0, 30.0)
MAX_CHROMA = 0.03  # the silhouette's default `silhouette_doubt_max_chroma`
BLEED_PX, BLEED_MIN_CHANGE = 1, 8.0  # the silhouette's defaults


def as_video(image_bgr: np.ndarray) -> np.ndarray:
    """`image_bgr` through a JPEG coder at quality 90 (OpenCV's default sampling: colour at half resolution)."""
    return cv2.imdecode(cv2.imencode(".jpg", image_bgr, [cv2.IMWRITE_JPEG_QUALITY, 90])[1], cv2.IMREAD_COLOR)


def coded_car(model_id: int, colour: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The car and its shadow on a grainy road, both coded as video: frame, background, the shadow beside the car
    (within 2 px of it, darkened by over 0.3) and the car's inside (2 px in from its fully covered pixels)."""
    road = np.clip(100 + np.random.default_rng(0).normal(0.0, 4.0, (720, 1280, 1)), 0, 255).repeat(3, axis=2)
    road = road.astype(np.uint8)
    model = model_by_id(model_id)
    render = render_car(model, model.palette[colour][1], POSE, CAMERA, road)
    car = (render.coverage > 0).astype(np.uint8)
    beside = (cv2.dilate(car, np.ones((5, 5), np.uint8)) > 0) & (car == 0)
    shadow = beside & (shadow_darkening(CAMERA, model, POSE, Lighting()) > 0.3)
    inside = cv2.erode((render.coverage >= 1).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    return as_video(render.image_bgr), as_video(road), shadow, inside


def test_a_pixels_chroma_is_its_larger_colour_difference():
    """Grey at any lightness has none; pure red's Cr is half its value (BT.601: 127.5), pure blue's Cb the same, and
    the renderer's tail-light red about 85 (exact to 1e-3 grey levels)."""
    pixels = np.array([[[0, 0, 0], [128, 128, 128], [255, 255, 255], [0, 0, 255], [255, 0, 0], [26, 20, 190]]], np.uint8)
    expected = [0.0, 0.0, 0.0, 127.5, 127.5, abs(-0.081312 * 26 - 0.418688 * 20 + 0.5 * 190)]
    assert chroma(pixels)[0] == pytest.approx(expected, abs=1e-3)


def test_a_shadow_keeps_the_roads_chromaticity_and_paint_does_not():
    """Exact: a grey road at half its light shifts by 0.0011 (the sums' +1); a red patch by 0.46."""
    road = np.full((4, 4, 3), 100, np.uint8)
    frame = road.copy()
    frame[:, :2] = 50
    frame[:, 2:] = (20, 20, 150)
    shift = chromaticity_shift(frame, road)
    assert shift[:, :2] == pytest.approx(100 / 301 - 50 / 151, abs=1e-6)
    assert shift[:, 2:] == pytest.approx(150 / 191 - 100 / 301, abs=1e-6)
    assert colour_change(frame, road)[:, :2] == pytest.approx(0.0, abs=1e-4)
    assert (colour_change(frame, road)[:, 2:] > 50).all()


@pytest.mark.parametrize("colour", [0, 1, 2])  # the Gallardo's yellow, orange and green
def test_beside_a_saturated_car_its_shadow_keeps_the_roads_chromaticity(colour: int):
    """Coded as video, the car's colour bleeds into its shadow: read pixel by pixel, only 0.53-0.61 of the shadow
    within 2 px of the car keeps the road's chromaticity (measured). Allowing a pixel's bleed (its least shift within
    1 px, next to a colour change), over 0.8 does (0.82-0.91); inside the car, at most 0.05 more of its pixels do
    (0.014-0.036: windows and dark trim beside the paint)."""
    frame, background, shadow, inside = coded_car(6, colour)
    plain = chromaticity_shift(frame, background) < MAX_CHROMA
    allowed = chromaticity_shift(frame, background, BLEED_PX, BLEED_MIN_CHANGE) < MAX_CHROMA
    assert shadow.sum() > 500
    assert plain[shadow].mean() < 0.7
    assert allowed[shadow].mean() > 0.8
    assert allowed[inside].mean() - plain[inside].mean() < 0.05


@pytest.mark.parametrize(("model_id", "colour"), [(6, 4), (4, 0)])  # the Gallardo's and the X5's black
def test_a_neutral_car_is_judged_as_without_the_allowance(model_id: int, colour: int):
    """A black car changes no colour to bleed: under 0.5 % of its inside is judged otherwise (measured 0.0-0.1 %)."""
    frame, background, _, inside = coded_car(model_id, colour)
    plain = chromaticity_shift(frame, background) < MAX_CHROMA
    allowed = chromaticity_shift(frame, background, BLEED_PX, BLEED_MIN_CHANGE) < MAX_CHROMA
    assert (plain != allowed)[inside].mean() < 0.005


def test_the_silhouette_doubts_a_saturated_cars_shadow_beside_it():
    """In the silhouette of the yellow car (its ROI), the shadow within 2 px of it is all in the mask; 0.53 of it is
    doubtful (maybe shadow) without the allowance and 0.85 with it (measured; bars 0.7 and 0.8)."""
    frame, background, shadow, inside = coded_car(6, 0)
    rows, cols = np.nonzero(shadow | inside)
    roi = (slice(rows.min() - 20, rows.max() + 20), slice(cols.min() - 20, cols.max() + 20))
    allowed = vehicle_silhouette(frame[roi], background[roi], RoiParams.from_config())
    plain = vehicle_silhouette(frame[roi], background[roi], RoiParams.from_config(silhouette_doubt_bleed_px=0))
    beside = shadow[roi] & allowed.mask
    assert beside.sum() > 500
    assert plain.doubtful[beside].mean() < 0.7
    assert allowed.doubtful[beside].mean() > 0.8


def test_the_bleed_settings_are_checked():
    with pytest.raises(ConfigError, match="silhouette_doubt_bleed_px: must be in \\[0, 101\\], got -1"):
        RoiParams.from_config(silhouette_doubt_bleed_px=-1)
    with pytest.raises(ConfigError, match="silhouette_doubt_bleed_min_change: must be in \\[0, 255\\], got -2"):
        RoiParams.from_config(silhouette_doubt_bleed_min_change=-2.0)
