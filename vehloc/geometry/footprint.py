"""Footprint lines of a vehicle (paper, Sec. II-E): the side line l_S and the front line l_F on the road.

The body's straight edges (`body_lines`) are grouped by the road direction they imply, not by their angle in
the image. A horizontal 3D line at any height maps through the inverse road homography to a road line of the
same direction (the map from the plane Z = h to the road, through the camera, is a scaling about the camera's
foot point), so every segment gives a road direction. A vertical edge maps to a road line through the foot
point; segments whose road line passes that close to it are taken as vertical (or too foreshortened to tell)
and dropped. The remaining directions have two modes 90 deg apart, the car's length and width axes, found
together as one direction modulo 90 deg.

The silhouette is mapped to the road too, every pixel as if it lay on it: a point of the car at some height
lands beyond its foot, away from the camera, so on a face turned to the camera nothing lands outside the car's
ground outline, and the edges of the hull of these road points that face the camera are the bottom edges of
those faces, touching where the car meets the ground (a side from tyre to tyre, an end along its bumper's
bottom). They vote for the axes with the segments, and the one seen longest in the image near an axis sets the
direction (segments on sloping beltlines do not). A bottom edge as long as a side from tyre to tyre marks the
length axis; an end's alone means an end-on view and the width axis; without either, an extent across the line
of sight longer than any vehicle is wide is the length.

Each footprint line is the road line of its axis tangent to the silhouette's road points on the camera's side:
on l_S that is the tyres' outer faces, within a few centimetres of the side. On l_F, where the end's overhang
stands above the road, it is the image of the end's bottom edge: at its height h the tangent lies beyond the
true end by h * d / (camera height - h) on the road, d the distance from the camera's foot (a few hundred mm
for a bumper seen from a few metres); the line's direction is the end's.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_range, params_from_config
from vehloc.geometry.body_lines import BodyLineParams, body_segments_px
from vehloc.geometry.end_bottom import EndBottomParams
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.silhouette import outline_corners_px


@dataclass(frozen=True)
class FootprintParams:
    """Segment extraction (`lines`), the grouping of segments by road direction, and the end's bottom edge below a
    plate (`end`)."""

    lines: BodyLineParams
    end: EndBottomParams
    vertical_max_deg: float
    direction_bandwidth_deg: float
    group_tolerance_deg: float
    hull_tolerance_deg: float
    hull_weight: float
    min_side_mm: float
    max_width_mm: float

    def __post_init__(self) -> None:
        for name in ("vertical_max_deg", "group_tolerance_deg", "hull_tolerance_deg"):
            check_range(name, getattr(self, name), 0.0, 90.0)
        check_range("direction_bandwidth_deg", self.direction_bandwidth_deg, 0.0, 90.0, low_open=True)
        check_range("hull_weight", self.hull_weight, 0.0)
        check_range("min_side_mm", self.min_side_mm, 0.0)
        check_range("max_width_mm", self.max_width_mm, 0.0, low_open=True)

    @classmethod
    def from_config(cls, **overrides: object) -> FootprintParams:
        """The settings of `conf/localize/footprint/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/footprint/default.yaml", overrides)


@dataclass(frozen=True, eq=False)
class FootprintLines:
    """A vehicle's footprint lines.

    ``length_heading_deg``: direction of the length axis on the road, from +X counter-clockwise seen from
    above, in [0, 180). Segments (N, 4) `x1 y1 x2 y2` frame px: along the length axis, along the width
    axis, and those dropped as vertical edges. Lines are homogeneous (3,), `a x + b y + c = 0` with
    `a^2 + b^2 = 1` and the vehicle on the positive side: in frame px (``*_px``) and on the road in mm
    (``*_mm``). ``side_*``: l_S, the long side at the bottom of the silhouette nearest the camera (through the
    tyres' outer faces); ``front_*``: l_F, the visible end (front or rear), the end's bottom edge: on the road it
    lies inside the true end by the overhang's height effect (see the module). ``*_faces_camera``: whether that
    face is turned to the camera (otherwise it is seen edge-on or not at all, and its line is the silhouette's
    extreme, beyond the face).
    ``quality``: how well all non-vertical segments agree with two perpendicular road directions, the
    weighted mean resultant length of four times their angles (1: all on the axes, 0: no structure).
    """

    length_heading_deg: float
    length_segments_px: np.ndarray
    width_segments_px: np.ndarray
    vertical_segments_px: np.ndarray
    side_line_px: np.ndarray
    front_line_px: np.ndarray
    side_line_mm: np.ndarray
    front_line_mm: np.ndarray
    side_faces_camera: bool
    front_faces_camera: bool
    quality: float

    @property
    def corner_mm(self) -> np.ndarray:
        """The footprint corner where l_S meets l_F, road mm (2,)."""
        point = np.cross(self.side_line_mm, self.front_line_mm)
        return point[:2] / point[2]


def unit_line(line: np.ndarray, inside_point: np.ndarray) -> np.ndarray:
    """Homogeneous line scaled so that its normal is a unit vector and `inside_point` is on its positive side."""
    line = np.asarray(line, dtype=float) / np.hypot(line[0], line[1])
    return line if line[:2] @ inside_point + line[2] >= 0 else -line


def foot_angle_deg(starts_mm: np.ndarray, ends_mm: np.ndarray, camera_foot_mm: np.ndarray) -> np.ndarray:
    """The angle (deg) at which the road line through each start and end point passes the camera's foot point,
    seen from the segment's middle: 0 for the road image of a vertical edge."""
    delta = ends_mm - starts_mm
    to_foot = np.asarray(camera_foot_mm, dtype=float) - (starts_mm + ends_mm) / 2
    cross = delta[:, 0] * to_foot[:, 1] - delta[:, 1] * to_foot[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        sine = np.abs(cross) / (np.linalg.norm(delta, axis=1) * np.linalg.norm(to_foot, axis=1))
    return np.degrees(np.arcsin(np.clip(sine, 0.0, 1.0)))


def road_direction_deg(starts_mm: np.ndarray, ends_mm: np.ndarray) -> np.ndarray:
    """Direction (deg, [0, 180)) of each road segment."""
    delta = ends_mm - starts_mm
    return np.degrees(np.arctan2(delta[:, 1], delta[:, 0])) % 180.0


def axes_modulo_90_deg(direction_deg: np.ndarray, weights: np.ndarray, bandwidth_deg: float) -> float:
    """The direction in [0, 90) around which the weighted directions cluster, either at it or at 90 deg from it:
    the highest peak of a von Mises kernel density of four times the angles, refined by the mean of those near it."""
    quadrupled = np.radians(4.0 * direction_deg)
    kappa = 1.0 / np.radians(4.0 * bandwidth_deg) ** 2
    grid = np.radians(np.arange(0.0, 360.0, 1.0))
    density = (weights[None, :] * np.exp(kappa * (np.cos(grid[:, None] - quadrupled[None, :]) - 1.0))).sum(axis=1)
    peak = grid[int(np.argmax(density))]
    near = np.abs(np.angle(np.exp(1j * (quadrupled - peak)))) < np.radians(4.0 * 2.0 * bandwidth_deg)
    mean = np.angle(np.sum(weights[near] * np.exp(1j * quadrupled[near])))
    return float(np.degrees(mean) / 4.0 % 90.0)


def angle_difference_deg(a_deg: np.ndarray, b_deg: float, period_deg: float) -> np.ndarray:
    """|a - b| folded into [0, period / 2]."""
    return np.abs((np.asarray(a_deg) - b_deg + period_deg / 2) % period_deg - period_deg / 2)


def visible_hull_edges(outline_mm: np.ndarray, camera_foot_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges of the outline's convex hull on the road that face the camera's foot point: their start and end
    points (M, 2) mm each."""
    hull = cv2.convexHull(outline_mm.astype(np.float32)).reshape(-1, 2).astype(float)
    starts, ends = hull, np.roll(hull, -1, axis=0)
    delta = ends - starts
    to_foot = np.asarray(camera_foot_mm, dtype=float) - starts
    centre = hull.mean(axis=0) - starts
    cross_foot = delta[:, 0] * to_foot[:, 1] - delta[:, 1] * to_foot[:, 0]
    cross_centre = delta[:, 0] * centre[:, 1] - delta[:, 1] * centre[:, 0]
    facing = (cross_foot * cross_centre < 0) & (np.linalg.norm(delta, axis=1) > 0)
    return starts[facing], ends[facing]


def extent_along_mm(points_mm: np.ndarray, direction_deg: float) -> float:
    """Extent (mm) of road points along a direction."""
    u = np.array([np.cos(np.radians(direction_deg)), np.sin(np.radians(direction_deg))])
    along = points_mm @ u
    return float(along.max() - along.min())


def tangent_line_mm(
    outline_mm: np.ndarray, direction_deg: float, camera_foot_mm: np.ndarray
) -> tuple[np.ndarray, bool]:
    """The road line of a direction tangent to the outline's road points on the camera's side, oriented with
    the vehicle on its positive side, and whether that face is turned to the camera (the foot point lies
    outside the band between the two tangents); otherwise the tangent nearer the foot point."""
    angle = np.radians(direction_deg)
    normal = np.array([-np.sin(angle), np.cos(angle)])
    offsets = outline_mm @ normal
    low, high = float(offsets.min()), float(offsets.max())
    foot = float(np.asarray(camera_foot_mm, dtype=float) @ normal)
    faces = foot <= low or foot >= high
    if foot - low <= high - foot:
        return np.array([normal[0], normal[1], -low]), faces
    return np.array([-normal[0], -normal[1], high]), faces


def length_axis(
    edge_mm: np.ndarray, on_axis: list[np.ndarray], outline_mm: np.ndarray, camera_foot_mm: np.ndarray,
    axis_deg: float, params: FootprintParams,
) -> int:
    """Which of the two axes (0: `axis_deg`, 1: `axis_deg` + 90) is the length axis, from the bottom edges near
    each (`edge_mm` lengths, `on_axis` masks): one as long as a side from tyre to tyre; else the other of an
    end's when only an end is seen; else the axis across the line of sight if the outline's extent along it
    is more than any vehicle's width."""
    longest_mm = [float(edge_mm[near].max(initial=0.0)) for near in on_axis]
    if max(longest_mm) >= params.min_side_mm:
        return int(np.argmax(longest_mm))
    if on_axis[0].any() != on_axis[1].any():
        return 0 if on_axis[1].any() else 1
    to_car = outline_mm.mean(axis=0) - camera_foot_mm
    sight_deg = np.degrees(np.arctan2(to_car[1], to_car[0]))
    across = int(np.argmax([angle_difference_deg(sight_deg, axis_deg + a, 180.0) for a in (0.0, 90.0)]))
    return across if extent_along_mm(outline_mm, axis_deg + 90.0 * across) > params.max_width_mm else 1 - across


def detect_footprint(
    roi_bgr: np.ndarray,
    mask: np.ndarray,
    offset_px: np.ndarray,
    road_to_image: ProjectiveTransform,
    camera_foot_mm: np.ndarray,
    params: FootprintParams,
    length_hint_deg: float | None = None,
) -> FootprintLines | None:
    """Footprint lines of the vehicle in an ROI; None when its edges show no road direction or its silhouette
    does not reach below the horizon. `length_hint_deg` (road deg), when given, says which of the two axes the
    edges show is the length axis (the one nearer it: e.g. across a licence plate's edges); else the edges'
    lengths and the outline's extent say.

    `roi_bgr`: the ROI crop (uint8 BGR); `mask`: its foreground (bool, the vehicle's pixels); `offset_px`:
    the ROI's top-left in the frame (x, y); `road_to_image`: road mm -> frame px; `camera_foot_mm`: the
    point of the road below the camera (`PinholeCamera.centre_mm[:2]`; from a calibrated homography alone, via
    `calibration.camera_from_homography`), whose image is the vertical vanishing point."""
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return None
    foot = np.asarray(camera_foot_mm, dtype=float)
    segments = body_segments_px(roi_bgr, mask, offset_px, params.lines)
    ends_mm = road_to_image.inverse(segments.reshape(-1, 2)).reshape(-1, 2, 2)
    valid = np.all(np.isfinite(ends_mm), axis=(1, 2))
    direction_deg = road_direction_deg(ends_mm[:, 0], ends_mm[:, 1])
    vertical = valid & (foot_angle_deg(ends_mm[:, 0], ends_mm[:, 1], foot) < params.vertical_max_deg)
    usable = valid & ~vertical
    if not usable.any():
        return None
    weights = np.hypot(segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1])
    quality = float(np.abs(np.sum(weights[usable] * np.exp(1j * np.radians(4.0 * direction_deg[usable]))))
                    / weights[usable].sum())

    outline_mm = road_to_image.inverse(outline_corners_px(mask, offset_px))
    outline_mm = outline_mm[np.all(np.isfinite(outline_mm), axis=1)]
    if len(outline_mm) < 3:
        return None
    starts, ends = visible_hull_edges(outline_mm, foot)
    informative = foot_angle_deg(starts, ends, foot) >= params.vertical_max_deg
    starts, ends = starts[informative], ends[informative]
    edge_deg = road_direction_deg(starts, ends)
    edge_mm = np.linalg.norm(ends - starts, axis=1)
    edge_px = np.linalg.norm(road_to_image(ends) - road_to_image(starts), axis=1)
    axis_deg = axes_modulo_90_deg(np.concatenate([direction_deg[usable], edge_deg]),
                                  np.concatenate([weights[usable], params.hull_weight * edge_px]),
                                  params.direction_bandwidth_deg)
    on_axis = [angle_difference_deg(edge_deg, axis_deg + a, 180.0) <= params.hull_tolerance_deg for a in (0.0, 90.0)]
    length = length_axis(edge_mm, on_axis, outline_mm, foot, axis_deg, params)
    candidates = [(edge_px[i], edge_deg[i] - 90.0 * k) for k in (0, 1) for i in np.flatnonzero(on_axis[k])]
    if candidates:  # the bottom edge seen longest in the image sets the direction
        axis_deg = max(candidates)[1]
    if length_hint_deg is not None:
        length = int(angle_difference_deg(axis_deg + 90.0, length_hint_deg, 180.0)
                     < angle_difference_deg(axis_deg, length_hint_deg, 180.0))
    length_heading_deg = float((axis_deg + 90.0 * length) % 180.0)
    groups = [usable & (angle_difference_deg(direction_deg, length_heading_deg + a, 180.0)
                        <= params.group_tolerance_deg) for a in (0.0, 90.0)]

    side_mm, side_faces = tangent_line_mm(outline_mm, length_heading_deg, foot)
    front_mm, front_faces = tangent_line_mm(outline_mm, length_heading_deg + 90.0, foot)
    inside_px = np.asarray(offset_px, dtype=float) + np.argwhere(mask).mean(axis=0)[::-1]
    side_px, front_px = (unit_line(road_to_image.map_lines(line)[0], inside_px) for line in (side_mm, front_mm))
    return FootprintLines(
        length_heading_deg=length_heading_deg,
        length_segments_px=segments[groups[0]],
        width_segments_px=segments[groups[1]],
        vertical_segments_px=segments[vertical],
        side_line_px=side_px,
        front_line_px=front_px,
        side_line_mm=side_mm,
        front_line_mm=front_mm,
        side_faces_camera=side_faces,
        front_faces_camera=front_faces,
        quality=quality,
    )
