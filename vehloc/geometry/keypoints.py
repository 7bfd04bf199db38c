"""The paper's key footprint points (Sec. II-E) and its placement of the box (Sec. II-F).

The plate branch, first: O is the footprint point below the plate's middle P, where the image of the
vertical through P (towards the camera's vertical vanishing point) meets the end's bottom edge, found on the
image's profile below the plate (`vehloc.geometry.end_bottom`), or, where that edge is not found, the front
line l_F; C lies along the length axis, into the vehicle: perpendicular to the line through the rear lamps either
side of the plate, where a pair is found (`vehloc.geometry.lamps`), else to the plate's upper and lower edges on the
road, or along the body's lines, whichever puts the predicted model's shape over more of the silhouette; the box's
visible end is stuck to O_W with its long centreline along O_W C_W. The plate also says which of the two axes
the body's edges show is the length axis (the one across the plate's edges): an end seen head-on shows little
of its sides. A plate-like part that no
plate could be by its width on the road, at any height a plate is mounted at (a bright band on the roof of a
small, far car), is not taken: the best candidate that can be a plate is. A small plate (its sides its colour's
outline, not found on the edges) gives way to two wheels. The wheel branch, when
no plate is taken: the two near tyres' contacts on the side line l_S (the outer faces' contacts with the
road, where l_S touches the tyres; taken from the tyres themselves, as a shadow beside the car can push the
silhouette's l_S outwards; l_S's direction is the one from contact to contact, their road points held the
predicted model's wheelbase apart where `wheels.hold_wheelbase`), Q their middle on the road, C perpendicular to
l_S, into the vehicle; the box's near side is stuck to Q_W between the axles with its
short centreline along Q_W C_W. Where one wheel is found (`wheels.one_wheel`), Q lies half the predicted model's
wheelbase from its contact along l_S, on the side the body reaches to, and l_S gives the direction (branch `wheel`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from vehloc.config import build_params
from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.data.specs import VehicleSpec
from vehloc.geometry.end_bottom import EndBottomParams, end_bottom_px
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.footprint import FootprintLines, FootprintParams, detect_footprint
from vehloc.geometry.lamps import LampParams, rear_lamps
from vehloc.geometry.model_fit import coverage, overlap
from vehloc.geometry.placement import VehicleBox, direction_of, heading_of, place_on_end, place_on_side
from vehloc.geometry.plate import Plate, PlateParams, plate_candidates
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.projective import HorizonError, ProjectiveTransform
from vehloc.geometry.roi import Silhouette
from vehloc.geometry.silhouette_start import lower_outline_px
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.wheels import WheelParams, detect_wheels

C_DISTANCE_MM = 1000.0
"""How far along the reference direction the paper's point C is taken."""
END_DEPTH_MM = 150.0
"""The depth of a vehicle's end face, for the height of its lowest point."""
CHOICE_SUPERSAMPLE = 4
"""The grid (times the image's resolution) on which placements' shapes are overlapped with the silhouette."""


@dataclass(frozen=True)
class DetectorParams:
    """The settings of the three detectors (`conf/footprint`, `conf/plate`, `conf/wheels`)."""

    footprint: FootprintParams
    plate: PlateParams
    wheels: WheelParams

    @classmethod
    def from_config(cls) -> DetectorParams:
        return cls(FootprintParams.from_config(), PlateParams.from_config(), WheelParams.from_config())

    @classmethod
    def from_mapping(cls, values: Mapping[str, object]) -> DetectorParams:
        """From a composed config holding the `footprint`, `plate` and `wheels` groups."""
        return cls(build_params(FootprintParams, values["footprint"], "footprint"),
                   build_params(PlateParams, values["plate"], "plate"),
                   build_params(WheelParams, values["wheels"], "wheels"))


@dataclass(frozen=True)
class Placement:
    """The paper's estimate: the box, the branch (`plate` or `wheels`), the key point (O or Q) and C on the
    road, and the distance that sets the heading (for its uncertainty)."""

    box: VehicleBox
    kind: str
    key_point_mm: np.ndarray
    c_point_mm: np.ndarray
    baseline_mm: float


def inward(heading_deg: float, point_mm: np.ndarray, camera_foot_mm: np.ndarray) -> np.ndarray:
    """The road direction of `heading_deg` (or its opposite) that points from `point_mm` away from the camera."""
    direction = direction_of(heading_deg)
    return direction if direction @ (point_mm - camera_foot_mm) >= 0 else -direction


def end_bottom_height_mm(shape: VehicleShape, visible_end: str | None) -> float:
    """How high the lowest point of the vehicle's end face stands (its bumper's lower edge): from the shape's
    points within `END_DEPTH_MM` of that end (`front`, `rear`, or the mean of both when unknown)."""
    points = shape.points_mm
    heights = {}
    for end, sign in (("front", 1.0), ("rear", -1.0)):
        x = sign * points[:, 0]
        heights[end] = float(points[x >= x.max() - END_DEPTH_MM, 2].min())
    return heights[visible_end] if visible_end in heights else (heights["front"] + heights["rear"]) / 2


def lowered_line_mm(line_mm: np.ndarray, height_mm: float, camera_centre_mm: np.ndarray) -> np.ndarray:
    """The road line below a horizontal 3D line at `height_mm` whose image maps to the road as `line_mm` (the
    homography takes every point of it along the camera's ray down to the road, too far by the factor
    camera height / (camera height - height)): the line scaled about the camera's foot."""
    k = (camera_centre_mm[2] - height_mm) / camera_centre_mm[2]
    a, b, c = line_mm
    at_foot = a * camera_centre_mm[0] + b * camera_centre_mm[1]
    return np.array([a, b, k * (at_foot + c) - at_foot])


def lowered_points_mm(points_mm: np.ndarray, height_mm: float, camera_centre_mm: np.ndarray) -> np.ndarray:
    """The road points (N, 2) below points `height_mm` above the road whose images map to the road as `points_mm`:
    each scaled towards the camera's foot by (camera height - height) / camera height (the point form of
    `lowered_line_mm`)."""
    foot_mm = np.asarray(camera_centre_mm, dtype=float)[:2]
    k = (camera_centre_mm[2] - height_mm) / camera_centre_mm[2]
    return foot_mm + k * (np.asarray(points_mm, dtype=float).reshape(-1, 2) - foot_mm)


def level_lines_direction_deg(lines_px: np.ndarray, road_to_image: ProjectiveTransform) -> float:
    """The road direction (deg, [0, 180)) of level 3D lines seen as the image lines `lines_px` (n, 3), their mean:
    each maps by the inverse homography to a road line of its own direction."""
    road_lines = road_to_image.inverse.map_lines(np.atleast_2d(lines_px))
    doubled = 2.0 * np.arctan2(-road_lines[:, 0], road_lines[:, 1])
    return float(np.degrees(np.angle(np.exp(1j * doubled).sum())) / 2.0 % 180.0)


def plate_width_heading_deg(plate: Plate, road_to_image: ProjectiveTransform) -> float:
    """The road direction (deg, [0, 180)) of the plate's upper and lower edges: level lines across the vehicle's end."""
    return level_lines_direction_deg(np.stack([plate.upper_line_px, plate.lower_line_px]), road_to_image)


def rear_lamps_heading_deg(plate: Plate, roi_bgr: np.ndarray, mask: np.ndarray, offset: np.ndarray,
                           road_to_image: ProjectiveTransform, params: LampParams,
                           visible_end: str | None) -> float | None:
    """The length axis (deg, [0, 180)) perpendicular to the line through the rear lamps either side of the plate
    (`vehloc.geometry.lamps`); None when they are off, not found, or the end in view is known to be the front."""
    if not params.enabled or visible_end == "front":
        return None
    lamps = rear_lamps(roi_bgr, mask, offset, plate.centre_px, params)
    if lamps is None:
        return None
    return (level_lines_direction_deg(lamps.line_px, road_to_image) + 90.0) % 180.0


def best_overlap(placements: list[Placement], camera: PinholeCamera, shape: VehicleShape, roi: Box,
                 mask: np.ndarray) -> Placement:
    """Of placements of the same vehicle, the one whose box, the predicted model's shape standing on it, overlaps
    the silhouette `mask` (its ROI's) most (`vehloc.geometry.model_fit.overlap`; the first on a tie); a lone one
    as it is."""
    if len(placements) == 1:
        return placements[0]
    weights = np.asarray(mask, dtype=np.float32)
    scores = [overlap(coverage(camera, shape, p.box, roi, CHOICE_SUPERSAMPLE), weights) for p in placements]
    return placements[int(np.argmax(scores))]


def plate_widths_mm(plate: Plate, road_to_image: ProjectiveTransform, camera_height_mm: float,
                    max_height_mm: float) -> tuple[float, float] | None:
    """The widths (mm) the plate can have, lowest and highest: its lower edge mapped to the road is its width
    stretched by H / (H - h) for a plate h above the road seen from a camera H high, with h from 0 to
    `max_height_mm`; None when that edge lies at or above the horizon."""
    lower_edge_mm = road_to_image.inverse(plate.corners_px[[3, 2]])
    if not np.all(np.isfinite(lower_edge_mm)):
        return None
    road_width_mm = float(np.linalg.norm(lower_edge_mm[1] - lower_edge_mm[0]))
    return road_width_mm * max(0.0, 1.0 - max_height_mm / camera_height_mm), road_width_mm


def implausible_plate(plate: Plate, calibration: CameraCalibration, params: PlateParams) -> str | None:
    """Why the plate cannot be one by its size on the road (None when it can): no width it could have, at any
    height it could be mounted at, lies in `params.width_range_mm`."""
    widths = plate_widths_mm(plate, calibration.road_to_image, calibration.camera.centre_mm[2], params.max_height_mm)
    low_mm, high_mm = params.width_range_mm
    if widths is None:
        return "a plate-like part's lower edge lies above the horizon"
    if widths[0] > high_mm or widths[1] < low_mm:
        return (f"a plate-like part would be {widths[0]:.0f}-{widths[1]:.0f} mm wide, not "
                f"{low_mm:.0f}-{high_mm:.0f} mm (plate.width_range_mm)")
    return None


def plausible_plate(candidates: list[Plate], calibration: CameraCalibration,
                    params: PlateParams) -> tuple[Plate | None, str | None]:
    """The best of the `candidates` (best first) that a plate can be by its size on the road, and, when none
    can, why the best cannot (None when there were no candidates)."""
    reasons = []
    for plate in candidates:
        why = implausible_plate(plate, calibration, params)
        if why is None:
            return plate, None
        reasons.append(why)
    return None, reasons[0] if reasons else None


def below_plate_mm(plate_centre_mm: np.ndarray, front_line_mm: np.ndarray,
                   camera_foot_mm: np.ndarray) -> np.ndarray | NotPlaced:
    """O: where the vertical through the plate's middle P meets the front footprint line, on the road. The
    vertical's image maps to the road as the line from the camera's foot through P's road image."""
    vertical = np.cross([*camera_foot_mm, 1.0], [*plate_centre_mm, 1.0])
    point = np.cross(vertical, front_line_mm)
    if abs(point[2]) < 1e-12:
        return NotPlaced(ReasonCode.PLATE_PARALLEL_TO_FRONT, "the plate's vertical runs parallel to the front footprint line")
    return point[:2] / point[2]


def below_plate_on_end_mm(plate: Plate, roi_bgr: np.ndarray, silhouette: Silhouette, offset: np.ndarray,
                          road_to_image: ProjectiveTransform, length_heading_deg: float, height_mm: float,
                          camera_centre_mm: np.ndarray, params: EndBottomParams) -> np.ndarray | None:
    """O from the end's own bottom edge (`vehloc.geometry.end_bottom`): where it crosses the vertical through the
    plate's middle P in the image (the end's across lines pass through the vanishing point of the direction
    across `length_heading_deg`), lowered to the road from `height_mm`; None when the edge is not found there."""
    vertical = np.cross([*plate.centre_px, 1.0], road_to_image.homogeneous(camera_centre_mm[:2])[0])
    plate_bottom = np.cross(vertical, plate.lower_line_px)
    across = direction_of(length_heading_deg + 90.0)
    vanishing = road_to_image.front_sign * (road_to_image.matrix @ np.array([across[0], across[1], 0.0]))
    width_px = float(np.linalg.norm(plate.corners_px[1] - plate.corners_px[0]))
    bottom = end_bottom_px(roi_bgr, silhouette.light_ratio, silhouette.mask, offset,
                           plate_bottom[:2] / plate_bottom[2], vertical, vanishing, width_px, params)
    if bottom is None:
        return None
    return lowered_points_mm(road_to_image.inverse.map_visible(bottom[None], "O"), height_mm, camera_centre_mm)[0]


def paper_placement(
    roi_bgr: np.ndarray, silhouette: Silhouette, roi: Box, calibration: CameraCalibration, spec: VehicleSpec,
    shape: VehicleShape, params: DetectorParams, visible_end: str | None = None,
) -> Placement | NotPlaced:
    """The paper's placement of the predicted model's box (`spec`) from the vehicle in `roi` (its crop and
    silhouette); `NotPlaced` saying why when the key points cannot be found or a key point maps to no road point
    (on or above the horizon).

    Plate branch: the length axis is perpendicular to the line through the rear lamps either side of the plate
    (else to the plate's edges) or along the body's lines, whichever box the silhouette covers better;
    O lies on the end's bottom edge below P, found in the image where the end meets the road
    (`below_plate_on_end_mm`), else on the front footprint
    line, the lower edge at the visible end of the silhouette trimmed of the shadow below it; either edge is the
    bumper's, a bumper's height above the road, so it is lowered to the road by that height, the predicted model's
    (`shape`; `visible_end` `front` or `rear` when known). Wheel branch: the lines of the whole silhouette, whose
    dark tyres reach the road."""
    try:
        return _placement(roi_bgr, silhouette, roi, calibration, spec, shape, params, visible_end)
    except HorizonError as err:
        return NotPlaced(ReasonCode.ON_HORIZON, str(err))


def _placement(
    roi_bgr: np.ndarray, silhouette: Silhouette, roi: Box, calibration: CameraCalibration, spec: VehicleSpec,
    shape: VehicleShape, params: DetectorParams, visible_end: str | None,
) -> Placement | NotPlaced:
    offset = np.array([roi.x0, roi.y0], dtype=float)
    plate, not_a_plate = plausible_plate(plate_candidates(roi_bgr, silhouette.mask, offset, params.plate),
                                         calibration, params.plate)
    if plate is not None and not plate.small:  # a small plate gives way to two wheels ...
        return _plate_placement(plate, roi_bgr, silhouette, roi, calibration, spec, shape, params, visible_end)
    wheels = _wheel_placement(roi_bgr, silhouette, offset, calibration, spec, params, not_a_plate)
    if plate is not None and (isinstance(wheels, NotPlaced) or wheels.kind == "wheel"):  # ... to two wheels only
        return _plate_placement(plate, roi_bgr, silhouette, roi, calibration, spec, shape, params, visible_end)
    return wheels


def _plate_placement(
    plate: Plate, roi_bgr: np.ndarray, silhouette: Silhouette, roi: Box, calibration: CameraCalibration,
    spec: VehicleSpec, shape: VehicleShape, params: DetectorParams, visible_end: str | None,
) -> Placement | NotPlaced:
    """The plate branch (the module's docstring)."""
    road_to_image, offset = calibration.road_to_image, np.array([roi.x0, roi.y0], dtype=float)
    across_plate_deg = (plate_width_heading_deg(plate, road_to_image) + 90.0) % 180.0
    lines = _footprint_lines(roi_bgr, silhouette.trimmed(), offset, calibration, params, across_plate_deg)
    if isinstance(lines, NotPlaced):
        return lines
    lamps_deg = rear_lamps_heading_deg(plate, roi_bgr, silhouette.mask, offset, road_to_image,
                                       params.plate.rear_lamps, visible_end)
    headings = [across_plate_deg if lamps_deg is None else lamps_deg, lines.length_heading_deg]
    placements = [_placed_below_plate(plate, length_axis_deg, lines, roi_bgr, silhouette, offset, calibration, spec,
                                      shape, params, visible_end) for length_axis_deg in headings]
    failed = [placed for placed in placements if isinstance(placed, NotPlaced)]
    if failed:
        return failed[0]
    return best_overlap(placements, calibration.camera, shape, roi, silhouette.mask)


def _placed_below_plate(
    plate: Plate, heading: float, lines: FootprintLines, roi_bgr: np.ndarray, silhouette: Silhouette,
    offset: np.ndarray, calibration: CameraCalibration, spec: VehicleSpec, shape: VehicleShape,
    params: DetectorParams, visible_end: str | None,
) -> Placement | NotPlaced:
    """The box along the length axis `heading` (deg), its visible end on O below the plate (the module's
    docstring)."""
    road_to_image, foot = calibration.road_to_image, calibration.camera.centre_mm[:2]
    height_mm = end_bottom_height_mm(shape, visible_end)
    o_mm = below_plate_on_end_mm(plate, roi_bgr, silhouette, offset, road_to_image, heading, height_mm,
                                 calibration.camera.centre_mm, params.footprint.end)
    if o_mm is None:
        p_mm = road_to_image.inverse.map_visible(plate.centre_px[None], "P")[0]
        front_line = lowered_line_mm(lines.front_line_mm, height_mm, calibration.camera.centre_mm)
        o_mm = below_plate_mm(p_mm, front_line, foot)
    if isinstance(o_mm, NotPlaced):
        return o_mm
    into = inward(heading, o_mm, foot)
    box = place_on_end(o_mm, into, spec.length_mm, spec.width_mm)
    return Placement(box, "plate", o_mm, o_mm + C_DISTANCE_MM * into, spec.length_mm / 2)


def _wheel_placement(
    roi_bgr: np.ndarray, silhouette: Silhouette, offset: np.ndarray, calibration: CameraCalibration,
    spec: VehicleSpec, params: DetectorParams, not_a_plate: str | None,
) -> Placement | NotPlaced:
    """The wheel branch; `not_a_plate`: why a plate-like part was not taken, told when no wheels are found."""
    road_to_image, foot = calibration.road_to_image, calibration.camera.centre_mm[:2]
    lines = _footprint_lines(roi_bgr, silhouette.mask, offset, calibration, params)
    if isinstance(lines, NotPlaced):
        return lines
    wheels = detect_wheels(roi_bgr, silhouette.mask, offset, road_to_image, foot, params.wheels, spec.wheelbase_mm)
    if wheels is not None and len(wheels.wheels) == 1 and params.wheels.one_wheel and spec.wheelbase_mm:
        return one_wheel_placement(wheels.wheels[0].outer_contact_px, lines.length_heading_deg, silhouette.mask, offset,
                                   calibration, spec, params.wheels.one_wheel_margin_fraction)
    if wheels is None or len(wheels.wheels) < 2:
        found = "one wheel" if wheels is not None else "no wheel"
        if wheels is not None and params.wheels.one_wheel:
            found += ", and the model has no wheelbase to place it by"
        return NotPlaced(ReasonCode.NO_KEY_POINTS, f"neither a licence plate nor two wheels found (found {found}"
                                                   f"{'' if not_a_plate is None else '; ' + not_a_plate})")
    contacts_px = np.array([w.outer_contact_px for w in wheels.wheels])
    contacts_mm = road_to_image.inverse.map_visible(contacts_px, "tyre contact")
    if params.wheels.hold_wheelbase and spec.wheelbase_mm:
        contacts_mm = held_at_wheelbase(contacts_px, contacts_mm, road_to_image, spec.wheelbase_mm)
    q_mm = contacts_mm.mean(axis=0)
    into = inward(heading_of(contacts_mm[1] - contacts_mm[0]) + 90.0, q_mm, foot)
    box = place_on_side(q_mm, into, spec.length_mm, spec.width_mm)
    return Placement(box, "wheels", q_mm, q_mm + C_DISTANCE_MM * into, float(np.linalg.norm(contacts_mm[1] - contacts_mm[0])))


def held_at_wheelbase(contacts_px: np.ndarray, contacts_mm: np.ndarray, road_to_image: ProjectiveTransform,
                      wheelbase_mm: float) -> np.ndarray:
    """Two tyre contacts' road points (2, 2) held `wheelbase_mm` apart: the pair whose images lie nearest the measured
    contacts (`contacts_px`, least squares in pixels), started from their road points as read (`contacts_mm`). A pixel
    of error along the line of sight moves a far contact's road point many times as far as one across it; the
    wheelbase leaves the pair's direction to the pixels across it, which hold it."""
    from scipy.optimize import least_squares  # scipy on first use, as the model fit

    def pair_mm(values: np.ndarray) -> np.ndarray:
        half = wheelbase_mm / 2 * np.array([np.cos(values[2]), np.sin(values[2])])
        return np.stack([values[:2] - half, values[:2] + half])

    def residuals_px(values: np.ndarray) -> np.ndarray:
        return (road_to_image(pair_mm(values)) - contacts_px).ravel()

    along = contacts_mm[1] - contacts_mm[0]
    start = np.array([*contacts_mm.mean(axis=0), np.arctan2(along[1], along[0])])
    return pair_mm(least_squares(residuals_px, start, x_scale=[100.0, 100.0, 0.01]).x)


def one_wheel_placement(contact_px: np.ndarray, length_heading_deg: float, mask: np.ndarray, offset: np.ndarray,
                        calibration: CameraCalibration, spec: VehicleSpec, margin_fraction: float) -> Placement | NotPlaced:
    """One wheel found (the module's docstring): Q half the model's wheelbase from its outer contact (`contact_px`,
    frame px) along the side line l_S (`length_heading_deg`), towards the far end of the silhouette's bottom edge
    mapped to the road (the body reaches past the wheel to the other axle, only an overhang the other way); C
    perpendicular, into the vehicle. Not placed when the box's footprint reaches beyond the silhouette's bounding
    box grown by `margin_fraction` (a far side's wheel, or the body's bottom edge misread)."""
    road_to_image, foot = calibration.road_to_image, calibration.camera.centre_mm[:2]
    t_mm = road_to_image.inverse.map_visible(np.asarray(contact_px, dtype=float)[None], "tyre contact")[0]
    along = direction_of(length_heading_deg)
    bottom_mm = road_to_image.inverse.map_visible(lower_outline_px(mask, offset), "the silhouette's bottom edge")
    reach_mm = np.percentile((bottom_mm - t_mm) @ along, [5.0, 95.0])
    if reach_mm[1] < -reach_mm[0]:
        along = -along
    q_mm = t_mm + along * spec.wheelbase_mm / 2
    into = inward(length_heading_deg + 90.0, q_mm, foot)
    box = place_on_side(q_mm, into, spec.length_mm, spec.width_mm)
    outside = footprint_outside_silhouette(box, road_to_image, mask, offset, margin_fraction)
    if outside is not None:
        return NotPlaced(ReasonCode.NO_KEY_POINTS, f"neither a licence plate nor two wheels found (found one wheel, "
                                                   f"whose placement {outside})")
    return Placement(box, "wheel", q_mm, q_mm + C_DISTANCE_MM * into, spec.wheelbase_mm / 2)


def footprint_outside_silhouette(box: VehicleBox, road_to_image: ProjectiveTransform, mask: np.ndarray,
                                 offset: np.ndarray, margin_fraction: float) -> str | None:
    """Why a box's footprint does not lie in the silhouette's bounding box grown by `margin_fraction` of its size
    each way (the footprint is under the body seen), or None when it does."""
    tight = Box.tight(mask)
    low, high = np.array([tight.x0, tight.y0], float) + offset, np.array([tight.x1, tight.y1], float) + offset
    grown = margin_fraction * (high - low)
    corners_px = road_to_image(box.corners_mm())
    beyond = np.maximum(low - grown - corners_px, corners_px - high - grown).max(axis=1)
    if beyond.max() <= 0:
        return None
    return f"reaches {beyond.max():.0f} px beyond the vehicle's silhouette"


def _footprint_lines(roi_bgr: np.ndarray, mask: np.ndarray, offset: np.ndarray, calibration: CameraCalibration,
                     params: DetectorParams, length_hint_deg: float | None = None) -> FootprintLines | NotPlaced:
    lines = detect_footprint(roi_bgr, mask, offset, calibration.road_to_image, calibration.camera.centre_mm[:2],
                             params.footprint, length_hint_deg)
    if lines is None:
        return NotPlaced(ReasonCode.NO_FOOTPRINT_LINES, "no footprint lines: the vehicle's edges show no road direction")
    return lines
