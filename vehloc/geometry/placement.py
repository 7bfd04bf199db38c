"""The box of a vehicle's dimensions on the road plane (the paper's Sec. II-F): where it stands, which way it
points, and its four footprint corners, placed from one key point on the road and a direction.

Two placements, as in the paper: the plate branch sticks the middle of the box's visible end (front or rear)
to the key point O_W and lays the box's long centreline along O_W C_W; the wheel branch sticks the middle of
the box's near side, between its axles, to the key point Q_W and lays its short centreline along Q_W C_W.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


def unit(vector: np.ndarray) -> np.ndarray:
    """The vector scaled to length 1 (ValueError for a zero vector)."""
    vector = np.asarray(vector, dtype=float)
    norm = float(np.linalg.norm(vector))
    if norm == 0.0 or not np.isfinite(norm):
        raise ValueError("a direction needs a non-zero finite vector")
    return vector / norm


def heading_of(direction: np.ndarray) -> float:
    """Heading (deg, from +X counter-clockwise, in (-180, 180]) of a road direction."""
    return float(np.degrees(np.arctan2(direction[1], direction[0])))


def direction_of(heading_deg: float) -> np.ndarray:
    """Unit road direction of a heading."""
    angle = np.radians(heading_deg)
    return np.array([np.cos(angle), np.sin(angle)])


def axis_difference_deg(a_deg: float, b_deg: float) -> float:
    """Signed difference a - b of two length-axis orientations, folded into [-90, 90) (front and rear alike)."""
    return float((a_deg - b_deg + 90.0) % 180.0 - 90.0)


def heading_difference_deg(a_deg: float, b_deg: float) -> float:
    """Signed difference a - b of two headings, folded into [-180, 180)."""
    return float((a_deg - b_deg + 180.0) % 360.0 - 180.0)


@dataclass(frozen=True)
class VehicleBox:
    """A vehicle's footprint on the road: the centre (mm), the heading of its front (deg) and its length and
    width (mm)."""

    centre_mm: np.ndarray
    heading_deg: float
    length_mm: float
    width_mm: float

    @property
    def forward(self) -> np.ndarray:
        return direction_of(self.heading_deg)

    @property
    def left(self) -> np.ndarray:
        forward = self.forward
        return np.array([-forward[1], forward[0]])

    def corners_mm(self) -> np.ndarray:
        """(4, 2) footprint corners: front-left, front-right, rear-right, rear-left (the scene truth's order)."""
        half_l, half_w = self.forward * self.length_mm / 2, self.left * self.width_mm / 2
        c = np.asarray(self.centre_mm, dtype=float)
        return np.array([c + half_l + half_w, c + half_l - half_w, c - half_l - half_w, c - half_l + half_w])

    def cuboid_mm(self, height_mm: float) -> np.ndarray:
        """(8, 3) corners of the box of this footprint and `height_mm`: the four footprint corners on the
        road, then the same four at the height."""
        corners = self.corners_mm()
        return np.vstack([np.column_stack([corners, np.zeros(4)]), np.column_stack([corners, np.full(4, height_mm)])])


def place_on_end(end_middle_mm: np.ndarray, inward: np.ndarray, length_mm: float, width_mm: float) -> VehicleBox:
    """The plate branch: the box whose visible end (front or rear) has its middle at `end_middle_mm` (O_W) and
    whose long centreline runs from there along `inward` (towards C_W, into the vehicle). The heading points
    against `inward`: the visible end is taken for the front (see `VehicleBox` for the other way round)."""
    inward = unit(inward)
    centre = np.asarray(end_middle_mm, dtype=float) + inward * length_mm / 2
    return VehicleBox(centre, heading_of(-inward), length_mm, width_mm)


def place_on_side(side_middle_mm: np.ndarray, inward: np.ndarray, length_mm: float, width_mm: float) -> VehicleBox:
    """The wheel branch: the box whose near side has its middle point between the axles at `side_middle_mm`
    (Q_W) and whose short centreline runs from there along `inward` (towards C_W, across the vehicle). The
    heading is the length axis to the left of `inward`; which way is front is decided by the caller."""
    inward = unit(inward)
    centre = np.asarray(side_middle_mm, dtype=float) + inward * width_mm / 2
    return VehicleBox(centre, heading_of(np.array([-inward[1], inward[0]])), length_mm, width_mm)


def between_axles(box: VehicleBox, axle_middle_x_mm: float) -> VehicleBox:
    """A wheel placement's box (its side's middle on the key point Q, its front known) moved along its length so
    that the middle between its axles lies on Q instead: its centre `axle_middle_x_mm` behind where it was (the
    axles' middle that far ahead of the box's)."""
    return replace(box, centre_mm=np.asarray(box.centre_mm, dtype=float) - box.forward * axle_middle_x_mm)


def facing(box: VehicleBox, heading_deg: float) -> VehicleBox:
    """The same box with its front turned to the side of `heading_deg` (e.g. the direction it drove in)."""
    if abs(heading_difference_deg(box.heading_deg, heading_deg)) <= 90.0:
        return box
    return VehicleBox(box.centre_mm, heading_difference_deg(box.heading_deg + 180.0, 0.0), box.length_mm, box.width_mm)
