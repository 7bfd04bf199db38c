"""A vehicle's footprint centre from one edge of its box and its recognised model's shape.

The background model's box of a vehicle is not its footprint: its bottom is the lowest pixel of the silhouette
(a bumper's lower edge a few hundred millimetres above the road, and the cast shadow next to it where the shadow test
leaves some), its top the highest (the roof's far edge, at the model's height). A point h mm high, seen from a camera
H mm up, lands on the road H / (H - h) times as far from the camera's foot, so a path of such points runs that much
too fast. Given the model's shape and the heading of its path, the footprint centre at which the projected shape's
box has its edge's middle where the vehicle's box has it is the vehicle's reference point on the road: the top edge
is free of the road's shadow and depends on the model's height, the bottom edge on the shadow.
"""

from __future__ import annotations

import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.model_fit import shape_points_world
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.placement import VehicleBox

NEWTON_ITERATIONS = 8
NEWTON_STEP_MM = 10.0
TOLERANCE_MM = 0.5


def box_edge_px(box: Box, edge: str, block_px: float = 1.0, extra_inset_px: float = 0.0) -> np.ndarray:
    """The middle of a box's top or bottom row (px, pixel centres at integers), for a box found on an image shrunk
    `block_px` times (its rows `block_px` pixels high, the vehicle's edge anywhere within the outermost: at its
    middle on average), moved `extra_inset_px` further in (a background model that marks a pixel changed when the
    vehicle covers less than half of it draws the box that much too large)."""
    inset_px = (block_px - 1.0) / 2 + extra_inset_px
    return np.array([box.centre_px[0], box.y0 + inset_px if edge == "top" else box.y1 - 1.0 - inset_px])


def shape_pixels(camera: PinholeCamera, shape: VehicleShape, centre_mm: np.ndarray, heading_deg: float) -> np.ndarray:
    """The shape's points (M, 2 px) standing at `centre_mm` with `heading_deg`; NaN where behind the camera."""
    return camera.project(shape_points_world(shape, VehicleBox(np.asarray(centre_mm, float), heading_deg, 0.0, 0.0)))


def shape_edge_px(camera: PinholeCamera, shape: VehicleShape, centre_mm: np.ndarray, heading_deg: float,
                  edge: str) -> np.ndarray:
    """`box_edge_px` of the box the shape would have at `centre_mm` and `heading_deg` (its rows covered at least
    half: the top row half a pixel below the highest projected point, the bottom row half a pixel above the lowest);
    NaN where part of the shape is behind the camera."""
    pixels = shape_pixels(camera, shape, centre_mm, heading_deg)
    if not np.all(np.isfinite(pixels)):
        return np.full(2, np.nan)
    row = pixels[:, 1].min() + 0.5 if edge == "top" else pixels[:, 1].max() - 0.5
    return np.array([(pixels[:, 0].min() + pixels[:, 0].max()) / 2, row])


def box_mismatch(camera: PinholeCamera, shape: VehicleShape, box: Box, centre_mm: np.ndarray, heading_deg: float,
                 block_px: float = 1.0) -> float:
    """How far the box's width and height are from the shape's at `centre_mm`, beyond the two `block_px` its edges
    may be off by (the larger, relative to the shape's): a box that holds a neighbour too, or a part of the vehicle
    only, is far from it."""
    pixels = shape_pixels(camera, shape, centre_mm, heading_deg)
    expected = np.ptp(pixels, axis=0)
    observed = np.array([box.width_px, box.height_px], dtype=float)
    if not (np.all(np.isfinite(pixels)) and np.all(expected > 0)):
        return float("inf")
    return float(np.max(np.clip(np.abs(observed - expected) - 2.0 * block_px, 0.0, None) / expected))


def box_height_excess(camera: PinholeCamera, shape: VehicleShape, box: Box, centre_mm: np.ndarray,
                      heading_deg: float) -> float:
    """How much taller `box` is than the shape's box at `centre_mm` (a fraction of the shape's; NaN where the shape
    cannot be projected): the cast shadow and blur below a vehicle of the right model, the model's error besides."""
    pixels = shape_pixels(camera, shape, centre_mm, heading_deg)
    if not np.all(np.isfinite(pixels)) or np.ptp(pixels[:, 1]) <= 0:
        return float("nan")
    shape_height_px = float(np.ptp(pixels[:, 1]))
    return (box.height_px - shape_height_px) / shape_height_px


def centre_from_box(camera: PinholeCamera, shape: VehicleShape, box: Box, heading_deg: float, start_mm: np.ndarray,
                    edge: str, block_px: float = 1.0, extra_inset_px: float = 0.0) -> np.ndarray | NotPlaced:
    """The footprint centre (mm) at which the shape, heading `heading_deg`, has `box`'s `edge` middle
    (`box_edge_px`): Newton's method from `start_mm` (the road point under the box's bottom will do), its Jacobian by
    finite differences; a `NotPlaced` when it does not converge."""
    target = box_edge_px(box, edge, block_px, extra_inset_px)
    centre = np.asarray(start_mm, dtype=float).copy()
    for _ in range(NEWTON_ITERATIONS):
        here = shape_edge_px(camera, shape, centre, heading_deg, edge)
        steps = [shape_edge_px(camera, shape, centre + offset, heading_deg, edge)
                 for offset in (np.array([NEWTON_STEP_MM, 0.0]), np.array([0.0, NEWTON_STEP_MM]))]
        jacobian = np.column_stack([(step - here) / NEWTON_STEP_MM for step in steps])
        if not np.all(np.isfinite(jacobian)) or abs(np.linalg.det(jacobian)) < 1e-12:
            break
        move = np.linalg.solve(jacobian, target - here)
        centre = centre + move
        if float(np.linalg.norm(move)) < TOLERANCE_MM:
            return centre
    return NotPlaced(ReasonCode.ON_HORIZON, f"no footprint centre puts the model's box {edge} where the vehicle's is")
