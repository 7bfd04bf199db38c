"""The share of each outline pixel a vehicle covers, read from the frame's colours, against the renderer's exact
coverage; and what it does for the model fit of a far car, against its exact pose."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from conftest import LOW_VERGE
from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.edge_coverage import edge_coverage
from vehloc.geometry.model_fit import FitParams, fit_model, overlap
from vehloc.geometry.motion import PathHeading
from vehloc.geometry.pipeline.localize import fit_weights
from vehloc.geometry.placement import VehicleBox, axis_difference_deg
from vehloc.geometry.roi import RoiParams, vehicle_silhouette
from vehloc.synth.body import convex_parts_car_mm
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import CarPose, CarRender, render_car

ROAD_GREY = 100
THRESHOLD = 12.0  # the silhouette's default: a change of more than this in any channel is the vehicle's
FAR_CARS = [(9, 0, CarPose(-1500.0, 30000.0, 80.0)), (4, 1, CarPose(2000.0, 25000.0, 20.0))]


def far_car(model_id: int, colour: int, pose: CarPose) -> tuple[CarRender, np.ndarray, np.ndarray]:
    """The car over a plain road (no shadow, no noise), the background, and the threshold's mask."""
    model = model_by_id(model_id)
    background = np.full((720, 1280, 3), ROAD_GREY, np.uint8)
    render = render_car(model, model.palette[colour][1], pose, LOW_VERGE, background, shadow_strength=0.0)
    mask = np.abs(render.image_bgr.astype(np.float32) - background).max(axis=2) > THRESHOLD
    return render, background, mask


@pytest.mark.parametrize(("model_id", "colour", "pose"), FAR_CARS)
def test_the_share_read_from_the_colours_is_the_rendered_coverage(model_id: int, colour: int, pose: CarPose):
    """Where it is read, the share is the renderer's coverage: within 0.05 for half the pixels and within 0.15 for
    80 % (measured 0.00, and 0.02-0.06). Over the pixels the car partly covers, the threshold's in or out is off by
    more than 0.2 on average (measured 0.40-0.44), the share by less than 0.1 (0.04-0.05)."""
    render, background, mask = far_car(model_id, colour, pose)
    share, known = edge_coverage(render.image_bgr, background, mask, np.zeros_like(mask), 2, 15.0)
    assert known.sum() > 500
    error = np.abs(share - render.coverage)[known]
    assert np.median(error) <= 0.05 and np.quantile(error, 0.8) <= 0.15
    mixed = known & (render.coverage > 0.05) & (render.coverage < 0.95)
    assert np.abs(mask - render.coverage)[mixed].mean() > 0.2
    assert np.abs(share - render.coverage)[mixed].mean() < 0.1


def test_doubtful_and_faint_pixels_are_not_read():
    """A doubtful pixel (maybe shadow), or one next to a vehicle barely distinct from the road, keeps its weight."""
    render, background, mask = far_car(*FAR_CARS[0])
    doubtful = np.zeros_like(mask)
    doubtful[:, :640] = True
    _, known = edge_coverage(render.image_bgr, background, mask, doubtful, 2, 15.0)
    assert known.any() and not known[:, :640].any()
    _, known = edge_coverage(render.image_bgr, background, mask, np.zeros_like(mask), 2, 255.0)
    assert not known.any()


@pytest.mark.parametrize(("model_id", "colour", "pose", "binary_mm", "soft_mm"),
                         [(*FAR_CARS[0], 11.0, 9.0), (*FAR_CARS[1], 15.9, 6.0)])
def test_a_far_car_is_fitted_closer_with_its_outline_shared(model_id: int, colour: int, pose: CarPose,
                                                           binary_mm: float, soft_mm: float):
    """25-30 m from a wide, low camera (a pixel is 150-250 mm of road there), from a start 180 mm and 3 deg off:
    fitted to the threshold's mask the car lands `binary_mm` off (measured), fitted to the weights with the
    outline's shares within `soft_mm` and 0.3 deg (measured 8.3 and 4.5 mm, 0.05 and 0.09 deg)."""
    render, background, mask = far_car(model_id, colour, pose)
    share, known = edge_coverage(render.image_bgr, background, mask, np.zeros_like(mask), 2, 15.0)
    model = model_by_id(model_id)
    roi = Box.tight(mask).enlarged(0.3, 1280, 720)
    shape = VehicleShape(convex_parts_car_mm(model))
    start = VehicleBox(np.array([pose.x_mm + 150.0, pose.y_mm - 100.0]), pose.heading_deg + 3.0,
                       model.length_mm, model.width_mm)

    def error_mm(weights: np.ndarray) -> tuple[float, float]:
        box = fit_model(LOW_VERGE, roi.crop(weights), roi, shape, start, FitParams.from_config()).box
        return (float(np.hypot(*(box.centre_mm - [pose.x_mm, pose.y_mm]))),
                abs(axis_difference_deg(box.heading_deg, pose.heading_deg)))

    assert error_mm(mask)[0] == pytest.approx(binary_mm, abs=1.0)
    position_mm, heading_deg = error_mm(np.where(known, share, mask))
    assert position_mm <= soft_mm and heading_deg <= 0.3


def test_the_overlap_is_best_where_the_shape_covers_the_pixel_s_share():
    """For bool coverage and weights the overlap is the intersection over union; a pixel weighing 0.3 matches best
    a shape that covers 0.3 of it."""
    covered = np.array([[1.0, 1.0, 0.0, 0.0]], np.float32)
    assert overlap(covered, np.array([[1.0, 0.0, 1.0, 0.0]])) == pytest.approx(1 / 3)
    weights = np.array([[1.0, 0.3]], np.float32)
    shares = np.linspace(0.0, 1.0, 11)
    scores = [overlap(np.array([[1.0, share]], np.float32), weights) for share in shares]
    assert shares[int(np.argmax(scores))] == pytest.approx(0.3)


def test_the_silhouette_carries_the_shares_and_only_a_still_vehicle_s_fit_reads_them():
    """`vehicle_silhouette` reads the shares within the band of its outline (NaN beyond it, None with no band); the
    fit of a vehicle without a path heading matches them, a moving one's (its heading its path's) the plain weights."""
    render, background, _ = far_car(*FAR_CARS[1])
    roi = Box.tight(render.coverage > 0).enlarged(0.3, 1280, 720)
    silhouette = vehicle_silhouette(roi.crop(render.image_bgr), roi.crop(background), RoiParams.from_config())
    read = ~np.isnan(silhouette.edge_share)
    around = cv2.blur(silhouette.mask.astype(np.float32), (7, 7))  # 0 or 1: over 3 px off the outline
    assert read.sum() > 200 and not (read & ((around < 1e-4) | (around > 1.0 - 1e-4))).any()
    shared = fit_weights(silhouette, None)
    assert np.array_equal(shared[read], silhouette.edge_share[read])
    assert np.array_equal(shared[~read], silhouette.weights[~read])
    moving = PathHeading(20.0, 0.5, 0.3, 30, 5000.0, 10.0)
    assert fit_weights(silhouette, moving) is silhouette.weights
    plain = vehicle_silhouette(roi.crop(render.image_bgr), roi.crop(background),
                               RoiParams.from_config(silhouette_edge_band_px=0))
    assert plain.edge_share is None and plain.weights_at_edges() is plain.weights
