"""The shadow a shape casts on the road, against exact geometry: a box's shadow under a sun 45 deg high is its
footprint stretched by its height away from the sun, and the cast search finds a cast it tries."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.cast_shadow import cast_shadow, fit_cast, sun_cast
from vehloc.geometry.model_fit import silhouette
from vehloc.geometry.placement import VehicleBox
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import CarPose, Lighting, render_car, shadow_darkening

CAMERA = PinholeCamera.look_at([0.0, -6000.0, 6500.0], [0.0, 9000.0, 0.0], 1000.0, 1280, 720)
ROI = Box(300, 150, 1000, 600)
BOX = VehicleBox(np.array([0.0, 12000.0]), 0.0, 4000.0, 1800.0)
CUBOID = VehicleShape.cuboid(4000.0, 1800.0, 1500.0)


@pytest.mark.parametrize(("azimuth_deg", "elevation_deg", "expected"), [
    (180.0, 45.0, (1.0, 0.0)), (0.0, 45.0, (-1.0, 0.0)), (270.0, 60.0, (0.0, 1.0 / np.sqrt(3.0))),
    (123.0, 90.0, (0.0, 0.0))])
def test_the_sun_casts_away_from_itself_by_its_elevations_cotangent(azimuth_deg, elevation_deg, expected):
    """Exact to 1e-12 road mm per mm of height."""
    np.testing.assert_allclose(sun_cast(azimuth_deg, elevation_deg), expected, atol=1e-12)


@pytest.mark.parametrize("elevation_deg", [0.0, -10.0, 95.0])
def test_a_sun_not_above_the_road_is_refused(elevation_deg):
    with pytest.raises(ValueError, match="elevation_deg"):
        sun_cast(0.0, elevation_deg)


@pytest.mark.parametrize("supersample", [1, 2])
def test_a_boxs_shadow_is_its_footprint_stretched_by_its_height(supersample):
    """Sun behind along -X at 45 deg: the roof's shadow lies 1,500 mm along +X, so the shadow is the flat
    rectangle from the rear end to 1,500 mm past the front: the same pixels, exactly, as that rectangle drawn."""
    shadow = cast_shadow(CAMERA, CUBOID, BOX, sun_cast(180.0, 45.0), ROI, supersample)
    stretched = VehicleBox(np.array([750.0, 12000.0]), 0.0, 5500.0, 1800.0)
    expected = silhouette(CAMERA, VehicleShape.cuboid(5500.0, 1800.0, 0.0), stretched, ROI, supersample)
    assert shadow.sum() > 1000
    np.testing.assert_array_equal(shadow, expected)


def test_an_overhead_sun_casts_the_footprint():
    shadow = cast_shadow(CAMERA, CUBOID, BOX, np.zeros(2), ROI, 1)
    np.testing.assert_array_equal(shadow, silhouette(CAMERA, VehicleShape.cuboid(4000.0, 1800.0, 0.0), BOX, ROI, 1))


@pytest.mark.parametrize("cast", [(0.0, -1.0), (-0.75, 0.0), (0.0, 0.0)])
def test_the_cast_search_finds_the_cast_of_the_dark_pixels(cast):
    """Dark pixels that are exactly the shadow of one of the casts tried (none: no shadow) give that cast. (A shadow
    cast away from this camera, along +Y, would lie wholly behind the box in the image: no pixel to find it by.)"""
    dark = cast_shadow(CAMERA, CUBOID, BOX, np.array(cast), ROI, 2) & ~silhouette(CAMERA, CUBOID, BOX, ROI, 2)
    np.testing.assert_allclose(fit_cast(CAMERA, CUBOID, BOX, ROI, dark, 2), cast, atol=1e-12)


def test_the_rendered_shadow_is_where_the_road_darkens():
    """`shadow_darkening` is the truth of `render_car`'s shadow: over a uniform road, the road's darkening outside
    the car equals it to a grey level's rounding, and it reaches beyond the car on the side away from the sun."""
    model = model_by_id(9)
    pose = CarPose(0.0, 12000.0, 0.0)
    lighting = Lighting.from_angles(180.0, 40.0, 0.45, 0.6)
    road = np.full((720, 1280, 3), 120, np.uint8)
    render = render_car(model, model.palette[0][1], pose, CAMERA, road, lighting)
    darkening = shadow_darkening(CAMERA, model, pose, lighting)
    outside = render.coverage == 0
    measured = 1.0 - render.image_bgr[..., 1].astype(float) / 120.0
    assert np.abs(measured - darkening)[outside].max() <= 0.5 / 120.0 + 1e-6
    columns = np.flatnonzero((darkening > 0.1).any(axis=0))
    car_columns = np.flatnonzero(render.mask.any(axis=0))
    assert columns.max() > car_columns.max()  # the shadow falls towards +X, away from a sun at 180 deg
