"""Wheels in a vehicle ROI (paper, Sec. II-E, after Hutter and Brewer's matching of 2-D ellipses to 3-D circles):
each near-side wheel's ellipse and its ground contact, and Q, the middle of two contacts.

Tyres are the darkest part of the lower silhouette; a rim is a hole in that darkness (taken at a few levels above the
darkest values, for light and for dark rims), and its outline is the image of a circle in a vertical plane, fitted by
an ellipse (`cv2.fitEllipse`) that the hole must fill, pixels within half a pixel of its outline not counted (a far
rim is a few pixels across), and grey inside (a lit lamp in a dark body is such a hole too). Only the near-side wheels
show their rims: the far side's are turned away. The circle's image gives its own geometry projectively: the polar of
the vertical vanishing point (the image of the camera's foot point) with respect to the ellipse is the wheel's
horizontal diameter, which meets the horizon in the vanishing point of the wheel's plane, and the polar of that point
is its vertical diameter, through the centre and the bottom of the tyre, which is concentric with the rim. Where the
vertical diameter leaves the silhouette, or sooner where the tyre's darkness ends above a lighter shadow, the tyre's
outer face touches the road; the tyre's contact (the middle of its tread) lies half a tyre width further in, across
the wheel's plane on the road, away from the camera. A wheel may show as a hole at several levels (a grey rim's hub
alone at the loosest); per place the largest rim stands. Of the wheels found, the best pair a wheelbase apart on a
line along both wheels' planes is kept (a lone wheel otherwise). Where that gives no pair, rims whose spokes are as
dark as the tyre are tried too: no gap between their spokes has the rim's shape, but the hull of the gaps has.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np

from vehloc.config import check_interval, check_range, params_from_config
from vehloc.geometry.chroma import chroma
from vehloc.geometry.projective import ProjectiveTransform


@dataclass(frozen=True)
class WheelParams:
    """Tyre darkness, rim ellipse tests, the tyre's extent and its width."""

    band_fraction: float
    dark_band_fraction: float
    tyre_to_rim_nominal: float
    dark_percentile: float
    dark_contrasts: tuple[float, ...]
    min_rim_px: float
    min_axis_ratio: float
    min_ellipse_overlap: float
    rim_outline_band_px: float
    rim_max_chroma: float
    spoked_rims: bool
    one_wheel: bool
    one_wheel_margin_fraction: float
    hold_wheelbase: bool
    tyre_to_rim_range: tuple[float, float]
    min_dark_tyre: float
    tyre_end_contrast: float
    edge_min_contrast: float
    edge_reach_px: float
    tyre_diameter_range_mm: tuple[float, float]
    tyre_width_mm: float
    wheelbase_range_mm: tuple[float, float]
    pair_tolerance_deg: float
    min_score: float
    model_wheelbase_tolerance: float
    partner_wheelbase_tolerance: float
    partner_min_ellipse_overlap: float
    partner_min_dark_tyre: float
    partner_min_score: float

    def __post_init__(self) -> None:
        check_range("band_fraction", self.band_fraction, 0.0, 1.0, low_open=True)
        check_range("dark_band_fraction", self.dark_band_fraction, 0.0, 1.0, low_open=True)
        check_range("dark_percentile", self.dark_percentile, 0.0, 100.0)
        check_range("min_rim_px", self.min_rim_px, 0.0, low_open=True)
        check_range("min_axis_ratio", self.min_axis_ratio, 0.0, 1.0)
        check_range("min_ellipse_overlap", self.min_ellipse_overlap, 0.0, 1.0)
        check_range("rim_outline_band_px", self.rim_outline_band_px, 0.0)
        check_range("rim_max_chroma", self.rim_max_chroma, 0.0)
        check_interval("tyre_to_rim_range", self.tyre_to_rim_range, 1.0)  # the ground is outside the rim
        check_range("tyre_to_rim_nominal", self.tyre_to_rim_nominal, *self.tyre_to_rim_range)
        for i, contrast in enumerate(self.dark_contrasts):
            check_range(f"dark_contrasts[{i}]", contrast, 0.0, 255.0, low_open=True)
        check_range("min_dark_tyre", self.min_dark_tyre, 0.0, 1.0)
        check_range("tyre_end_contrast", self.tyre_end_contrast, 0.0, 255.0, low_open=True)
        check_range("edge_min_contrast", self.edge_min_contrast, 0.0, 255.0)
        check_range("edge_reach_px", self.edge_reach_px, 0.0)
        check_interval("tyre_diameter_range_mm", self.tyre_diameter_range_mm, 0.0, low_open=True)
        check_range("tyre_width_mm", self.tyre_width_mm, 0.0)
        check_interval("wheelbase_range_mm", self.wheelbase_range_mm, 0.0, low_open=True)
        check_range("pair_tolerance_deg", self.pair_tolerance_deg, 0.0, 90.0)
        check_range("min_score", self.min_score, 0.0, 1.0)
        check_range("model_wheelbase_tolerance", self.model_wheelbase_tolerance, 0.0, 1.0)
        check_range("partner_wheelbase_tolerance", self.partner_wheelbase_tolerance, 0.0, 1.0)
        check_range("partner_min_ellipse_overlap", self.partner_min_ellipse_overlap, 0.0, 1.0)
        check_range("partner_min_dark_tyre", self.partner_min_dark_tyre, 0.0, 1.0)
        check_range("partner_min_score", self.partner_min_score, 0.0, 1.0)
        check_range("one_wheel_margin_fraction", self.one_wheel_margin_fraction, 0.0)

    @classmethod
    def from_config(cls, **overrides: object) -> WheelParams:
        """The settings of `conf/localize/wheels/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/wheels/default.yaml", overrides)


@dataclass(frozen=True, eq=False)
class Ellipse:
    """An ellipse in px: centre, semi-axes (major, minor) and the major axis's angle from +x towards +y (deg)."""

    centre_px: np.ndarray
    semi_axes_px: np.ndarray
    angle_deg: float

    @classmethod
    def from_rotated_rect(cls, rect: tuple) -> Ellipse:
        """From `cv2.fitEllipse`'s ((cx, cy), (width, height), angle)."""
        (cx, cy), (width, height), angle = rect
        if width >= height:
            return cls(np.array([cx, cy]), np.array([width, height]) / 2, float(angle) % 180.0)
        return cls(np.array([cx, cy]), np.array([height, width]) / 2, (float(angle) + 90.0) % 180.0)

    @property
    def conic(self) -> np.ndarray:
        """The symmetric 3x3 matrix C with `p^T C p = 0` on the ellipse (p homogeneous)."""
        theta = np.radians(self.angle_deg)
        rotation = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        shape = rotation @ np.diag(1.0 / self.semi_axes_px**2) @ rotation.T
        centre = self.centre_px
        return np.block([[shape, -(shape @ centre)[:, None]],
                         [-(shape @ centre)[None, :], np.array([[centre @ shape @ centre - 1.0]])]])

    def scaled(self, factor: float) -> Ellipse:
        """The ellipse scaled about its centre."""
        return Ellipse(self.centre_px, self.semi_axes_px * factor, self.angle_deg)

    def grown(self, by_px: float, least_px: float = 0.0) -> Ellipse:
        """The ellipse with each semi-axis `by_px` longer (shorter where negative), none under `least_px`."""
        return Ellipse(self.centre_px, np.maximum(self.semi_axes_px + by_px, least_px), self.angle_deg)

    def mask(self, shape: tuple[int, int]) -> np.ndarray:
        """Pixels (bool) inside the ellipse."""
        canvas = np.zeros(shape, np.uint8)
        cv2.ellipse(canvas, (tuple(self.centre_px), tuple(2 * self.semi_axes_px), self.angle_deg), 1, cv2.FILLED)
        return canvas.astype(bool)


@dataclass(frozen=True, eq=False)
class Wheel:
    """One near-side wheel in frame px.

    ``rim``: the fitted rim ellipse; ``tyre``: the rim ellipse scaled about its centre to reach the ground;
    ``outer_contact_px``: where the tyre's outer face meets the road (the lowest point of the tyre ellipse on
    its vertical diameter); ``contact_px``: the tyre's contact, half a tyre width further in; ``vertical_line_px``:
    the image of the wheel's vertical diameter (homogeneous); ``score`` in [0, 1]: how well the rim fills its ellipse times how dark the
    tyre is below it."""

    rim: Ellipse
    tyre: Ellipse
    outer_contact_px: np.ndarray
    contact_px: np.ndarray
    vertical_line_px: np.ndarray
    score: float


@dataclass(frozen=True, eq=False)
class Wheels:
    """Up to two near-side wheels (left to right in the image), ``q_px`` Q, the middle of their contacts on the road
    mapped back to the image (None with one wheel), and ``score``, the mean of their scores."""

    wheels: tuple[Wheel, ...]
    q_px: np.ndarray | None
    score: float


def meet(line_a: np.ndarray, line_b: np.ndarray) -> np.ndarray:
    """The homogeneous point where two homogeneous lines meet."""
    return np.cross(line_a, line_b)


def vertical_diameter(rim: Ellipse, vertical_vp: np.ndarray, horizon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The image (homogeneous line) of a wheel's vertical diameter, and the vanishing point (homogeneous) of the
    wheel's horizontal direction: the polar of the vertical vanishing point meets the horizon in the latter,
    whose polar is the former."""
    conic = rim.conic
    horizontal_vp = meet(conic @ vertical_vp, horizon)
    return conic @ horizontal_vp, horizontal_vp


def ground_crossing_px(mask: np.ndarray, start_px: np.ndarray, direction: np.ndarray, reach_px: float) -> float | None:
    """How far (px) from `start_px` along `direction` the silhouette ends: half-way between the last mask sample
    and the first one outside it, sampling every quarter pixel; None when it does not end within `reach_px`."""
    from scipy.ndimage import map_coordinates  # scipy on first use: a refused CLI answers sooner
    steps = np.arange(0.0, reach_px, 0.25)
    points = start_px + steps[:, None] * direction
    inside = map_coordinates(mask.astype(np.float32), [points[:, 1], points[:, 0]], order=0, mode="constant") > 0.5
    outside = np.flatnonzero(~inside)
    if len(outside) == 0 or outside[0] == 0:
        return None
    return float(steps[outside[0]] - 0.125)


def lower_part(mask: np.ndarray, fraction: float) -> np.ndarray:
    """The mask's pixels in the lower `fraction` of its rows' span."""
    rows = np.flatnonzero(mask.any(axis=1))
    part = mask.copy()
    part[: int(rows[0] + (1.0 - fraction) * (rows[-1] - rows[0]))] = False
    return part


RimCandidate = tuple[Ellipse, float, np.ndarray]
"""A rim fitted to an outline (ROI px), how well the outline fills it (`ellipse_overlap`) and its darkness level's
dark pixels."""


def dark_levels(roi_grey: np.ndarray, mask: np.ndarray, params: WheelParams) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """Per darkness level (dark rims need a low one): the tyre-dark pixels (uint8) of the ROI and the outlines of the
    holes in those of the silhouette's lower part."""
    band = lower_part(mask, params.band_fraction)
    darkest = np.percentile(roi_grey[lower_part(mask, params.dark_band_fraction)], params.dark_percentile)
    levels = []
    for contrast in params.dark_contrasts:
        dark = (roi_grey <= darkest + contrast).astype(np.uint8)
        contours, hierarchy = cv2.findContours(dark & band, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
        holes = [contour for contour, (_, _, _, parent) in zip(contours, hierarchy[0] if hierarchy is not None else [])
                 if parent >= 0]
        levels.append((dark, holes))
    return levels


def rim_fits(outlines: list[np.ndarray], dark: np.ndarray, params: WheelParams) -> list[RimCandidate]:
    """The ellipses fitted to outlines in one level's `dark` pixels that are rim-sized, round enough and filled by
    their outline (`ellipse_overlap` at least `min_ellipse_overlap`), each with that overlap and the level's dark
    pixels."""
    rims: list[RimCandidate] = []
    for outline in outlines:
        if len(outline) < 5:
            continue
        rim = Ellipse.from_rotated_rect(cv2.fitEllipse(outline.astype(np.float32)))
        minor, major = rim.semi_axes_px[1], rim.semi_axes_px[0]
        if minor < params.min_rim_px or minor < params.min_axis_ratio * major:
            continue
        hole = np.zeros_like(dark)
        cv2.drawContours(hole, [outline], -1, 1, cv2.FILLED)
        overlap = ellipse_overlap(rim, hole.astype(bool), params.rim_outline_band_px)
        if overlap >= params.min_ellipse_overlap:
            rims.append((rim, overlap, dark.astype(bool)))
    return rims


def ellipse_overlap(rim: Ellipse, hole: np.ndarray, band_px: float) -> float:
    """How well a hole (bool pixels) fills its fitted ellipse: one less the share of their union that is wrong, a
    pixel of the ellipse missing from the hole or one of the hole outside the ellipse, where pixels within `band_px`
    of the ellipse's outline are wrong neither way (which side of the outline they fall on is the digitization's
    call: at a rim a few pixels across, that band holds half its pixels or more)."""
    inside = rim.mask(hole.shape)
    inner, outer = rim.grown(-band_px).mask(hole.shape), rim.grown(band_px).mask(hole.shape)
    wrong = np.count_nonzero(inner & ~hole) + np.count_nonzero(hole & ~outer)
    return 1.0 - wrong / np.count_nonzero(inside | hole)


def rim_chroma(rim: Ellipse, colour: np.ndarray, band_px: float) -> float:
    """The median chroma (`vehloc.geometry.chroma.chroma`) inside a rim, `band_px` in from its outline. A rim is grey
    metal; a lit lamp in a dark body is a hole of its shape too, and coloured."""
    inner = rim.grown(-band_px, least_px=0.5).mask(colour.shape)
    return float(np.median(colour[inner])) if inner.any() else 0.0


def rim_candidates(roi_grey: np.ndarray, mask: np.ndarray, params: WheelParams, spoked: bool = False) -> list[RimCandidate]:
    """Ellipses fitted to the outlines of the holes in the tyre-dark pixels of the silhouette's lower part, at each
    darkness level, with how well each hole fills its ellipse (`ellipse_overlap`) and that level's dark
    pixels. A wheel may give a hole at several levels (its rim at a low one, only its hub at a higher one, where a
    grey rim counts as dark): all are kept, to be measured as wheels. With `spoked`, the outlines of spoked rims
    grouped from their gaps (`spoked_rims`) are tried too, after each level's holes."""
    return [candidate for dark, holes in dark_levels(roi_grey, mask, params)
            for candidate in rim_fits(holes + (spoked_rims(holes, dark.shape, params.min_rim_px) if spoked else []),
                                      dark, params)]


def spoked_rims(holes: list[np.ndarray], shape: tuple[int, int], spoke_px: float) -> list[np.ndarray]:
    """The outlines of rims whose spokes are as dark as the tyre: the gaps between the spokes are holes of their own,
    none the rim's shape; holes at most two `spoke_px` apart are grouped, and each group of three or more, none of
    them a third of the group's convex hull, gives that hull (the rim, its spokes' ends on it): a rim's own hole
    beside a few specks is no spoked rim."""
    if len(holes) < 3:
        return []
    canvas = np.zeros(shape, np.uint8)
    cv2.drawContours(canvas, holes, -1, 1, cv2.FILLED)
    reach = max(1, int(round(spoke_px)))
    grown = cv2.dilate(canvas, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * reach + 1,) * 2))
    _, labels = cv2.connectedComponents(grown)
    groups: dict[int, list[np.ndarray]] = {}
    for hole in holes:
        x, y = hole[0, 0]
        groups.setdefault(int(labels[y, x]), []).append(hole)
    rims = []
    for group in groups.values():
        hull = cv2.convexHull(np.concatenate(group))
        if len(group) >= 3 and max(cv2.contourArea(hole) for hole in group) < cv2.contourArea(hull) / 3:
            rims.append(hull)
    return rims


def best_per_place(found: list[tuple]) -> list[tuple]:
    """Of measured wheels (score first, rim second) whose rims' centres lie within half the larger semi-minor axis of
    each other (one wheel's holes at several darkness levels), the one with the largest rim: a hub's hole lies inside
    its rim's."""
    kept: list[tuple] = []
    for item in sorted(found, key=lambda item: -item[1].semi_axes_px[0]):
        rim = item[1]
        if all(np.linalg.norm(other.centre_px - rim.centre_px) >= max(other.semi_axes_px[1], rim.semi_axes_px[1]) / 2
               for other in (kept_item[1] for kept_item in kept)):
            kept.append(item)
    return kept


def conic_crossings(conic: np.ndarray, point_px: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The parameters t (real, possibly none) at which `point_px + t * direction` lies on a conic."""
    p, d = np.append(point_px, 1.0), np.append(direction, 0.0)
    roots = np.roots([d @ conic @ d, 2 * (d @ conic @ p), p @ conic @ p])
    return roots[np.isreal(roots)].real


def tyre_diameter_mm(
    tyre: Ellipse, vertical_vp: np.ndarray, centre_px: np.ndarray, road_to_image: ProjectiveTransform
) -> float:
    """The length on the road (mm) of the tyre's horizontal diameter, its ends mapped as if they lay on the road:
    the diameter itself, lengthened by the camera height / (camera height - wheel radius), a few per cent."""
    horizontal = tyre.conic @ vertical_vp
    direction = np.array([horizontal[1], -horizontal[0]]) / np.hypot(horizontal[0], horizontal[1])
    ends = centre_px + conic_crossings(tyre.conic, centre_px, direction)[:, None] * direction
    if len(ends) != 2:
        return 0.0
    ends_mm = road_to_image.inverse(ends)
    return float(np.linalg.norm(ends_mm[1] - ends_mm[0])) if np.all(np.isfinite(ends_mm)) else 0.0


def tyre_edge_px(grey: np.ndarray, start_px: np.ndarray, direction: np.ndarray, ground_px: float,
                 params: WheelParams) -> float:
    """The tyre's lower edge to a fraction of a pixel, near the ground found (`ground_px` along `direction` from
    `start_px`, ROI px): where the ROI's `grey` rises through halfway from the tyre's level (the lower quartile 1 to
    3 px before the ground found) to the road's just below (the median 1 to 2.5 px past it), the rise nearest it
    within `edge_reach_px`. A silhouette takes a pixel the tyre covers in part; the half level is where it covers
    half. The ground found stands where the road below is not `edge_min_contrast` lighter than the tyre, or no rise
    is that near."""
    from scipy.ndimage import map_coordinates

    def profile(steps: np.ndarray) -> np.ndarray:
        points = start_px + (ground_px + steps)[:, None] * direction
        return map_coordinates(grey, [points[:, 1], points[:, 0]], order=1, mode="nearest")

    tyre = float(np.percentile(profile(np.arange(-3.0, -0.99, 0.25)), 25))
    road = float(np.median(profile(np.arange(1.0, 2.51, 0.25))))
    if road - tyre < params.edge_min_contrast:
        return ground_px
    half = (tyre + road) / 2
    steps = np.arange(-params.edge_reach_px - 0.5, params.edge_reach_px + 0.5 + 1e-9, 0.125)
    grey_along = profile(steps)
    rises = np.flatnonzero((grey_along[:-1] <= half) & (grey_along[1:] > half))
    if len(rises) == 0:
        return ground_px
    k = rises[np.argmin(np.abs(steps[rises]))]
    edge = steps[k] + (half - grey_along[k]) / (grey_along[k + 1] - grey_along[k]) * 0.125
    return ground_px + float(edge) if abs(edge) <= params.edge_reach_px else ground_px


def measure_wheel(
    rim: Ellipse, overlap: float, dark: np.ndarray, grey: np.ndarray, mask: np.ndarray, offset_px: np.ndarray,
    vertical_vp: np.ndarray, horizon: np.ndarray, road_to_image: ProjectiveTransform, params: WheelParams,
) -> tuple[float, Ellipse, np.ndarray, float, np.ndarray, np.ndarray, bool] | None:
    """A rim (frame px) measured as a wheel: its score, the rim, the outer contact (frame px), the tyre's scale
    from the rim, the vertical diameter, the horizontal vanishing point (homogeneous) and whether the tyre is
    the nominal one (the silhouette not ending below it); None when the ground is not a tyre's depth below the
    rim, the tyre between them is not dark, or the tyre is not wheel-sized. The ground is where the silhouette ends
    below the rim (where it ends less than a tyre's depth below, the level's `dark` pixels carry it on: the
    silhouette's test took the tyre's lower part for the shadow below), or sooner where the tyre ends above a
    lighter shadow that the silhouette holds: where the ROI's `grey` first rises `tyre_end_contrast` above the
    tyre's own level (the lower quartile between rim and ground); then to a fraction of a pixel (`tyre_edge_px`)."""
    from scipy.ndimage import map_coordinates  # scipy on first use: a refused CLI answers sooner
    line, horizontal_vp = vertical_diameter(rim, vertical_vp, horizon)
    line = line / np.hypot(line[0], line[1])
    direction = np.array([line[1], -line[0]]) * (1.0 if -line[0] >= 0 else -1.0)  # down the image
    centre = rim.centre_px - (line[:2] @ rim.centre_px + line[2]) * line[:2]  # on the vertical diameter
    rim_bottom_px = float(conic_crossings(rim.conic, centre, direction).max(initial=0.0))
    if rim_bottom_px <= 0:
        return None
    low, high = params.tyre_to_rim_range
    start, search_px = centre - offset_px, high * rim_bottom_px + 2.0  # ROI px
    body = mask
    measured = ground_crossing_px(body, start, direction, search_px)
    if measured is not None and measured < low * rim_bottom_px:  # the silhouette ends within the tyre, whose lower
        body = mask | dark  # part was taken for the shadow below: the tyre's dark pixels carry it on
        measured = ground_crossing_px(body, start, direction, search_px)
    inside_tyre = rim_bottom_px + 1.0
    if measured is not None and measured > inside_tyre:
        below = start + np.arange(inside_tyre, measured, 0.25)[:, None] * direction
        level = np.percentile(map_coordinates(grey, [below[:, 1], below[:, 0]], order=1, mode="nearest"), 25)
        tyre = body & (grey <= level + params.tyre_end_contrast)
        tyre_end = ground_crossing_px(tyre, start + inside_tyre * direction, direction,
                                      measured - inside_tyre + 1.0)
        if tyre_end is not None:
            measured = min(measured, inside_tyre + tyre_end)
        measured = tyre_edge_px(grey, start, direction, measured, params)
    # where the silhouette ends a tyre below the rim, the ground is there; where it carries on below (a shadow
    # under the car), a tyre of the nominal size is tried too
    nominal = params.tyre_to_rim_nominal * rim_bottom_px
    reaches = [measured] if measured is not None and low * rim_bottom_px <= measured <= high * rim_bottom_px else []
    reaches += [nominal] if measured is None or measured > nominal else []
    for reach in reaches:
        tyre = start + np.linspace(rim_bottom_px, reach, 8)[1:-1, None] * direction
        tyre_dark = float(map_coordinates(dark.astype(np.float32), [tyre[:, 1], tyre[:, 0]], order=0).mean())
        score = overlap * tyre_dark
        diameter_mm = tyre_diameter_mm(rim.scaled(reach / rim_bottom_px), vertical_vp, centre, road_to_image)
        low_mm, high_mm = params.tyre_diameter_range_mm
        if tyre_dark >= params.min_dark_tyre and score >= params.min_score and low_mm <= diameter_mm <= high_mm:
            return score, rim, centre + reach * direction, reach / rim_bottom_px, line, horizontal_vp, reach == nominal
    return None


def wheel_pair(
    outer_mm: np.ndarray, plane_directions_mm: np.ndarray, scores: np.ndarray, params: WheelParams
) -> list[int]:
    """The indices of the best-scoring pair of wheels of one side (a wheelbase apart on the road, on a line along
    both wheels' planes within `pair_tolerance_deg`), left as found; the best wheel alone when no pair is."""
    def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.degrees(np.arccos(min(1.0, abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b))))))

    low, high = params.wheelbase_range_mm
    best: tuple[float, list[int]] = (float(scores.max()), [int(np.argmax(scores))])
    for i in range(len(scores)):
        for j in range(i + 1, len(scores)):
            between = outer_mm[j] - outer_mm[i]
            if (low <= np.linalg.norm(between) <= high
                    and max(angle_deg(between, plane_directions_mm[i]), angle_deg(between, plane_directions_mm[j]))
                    <= params.pair_tolerance_deg and scores[i] + scores[j] > best[0]):
                best = (float(scores[i] + scores[j]), [i, j])
    return best[1]


def detect_wheels(
    roi_bgr: np.ndarray,
    mask: np.ndarray,
    offset_px: np.ndarray,
    road_to_image: ProjectiveTransform,
    camera_foot_mm: np.ndarray,
    params: WheelParams,
    wheelbase_mm: float | None = None,
) -> Wheels | None:
    """The near-side wheels of the vehicle in an ROI, or None when no wheel scores `min_score`.

    `roi_bgr`: the ROI crop (uint8 BGR); `mask`: its foreground (bool); `offset_px`: the ROI's top-left in the
    frame (x, y); `road_to_image`: road mm -> frame px; `camera_foot_mm`: the road point below the camera
    (`PinholeCamera.centre_mm[:2]`), whose image is the vertical vanishing point; `wheelbase_mm`: the predicted
    model's, where known. Where fewer than two wheels are found so, a pair held to looser tests (`partner_*`) whose
    outer contacts lie that wheelbase apart (within `partner_wheelbase_tolerance` of it; 0: off) is taken instead."""
    if wheelbase_mm is not None and params.model_wheelbase_tolerance > 0:
        params = replace(params, wheelbase_range_mm=around(wheelbase_mm, params.model_wheelbase_tolerance))
    wheels = _detect_wheels(roi_bgr, mask, offset_px, road_to_image, camera_foot_mm, params)
    paired = wheels is not None and len(wheels.wheels) >= 2
    if wheelbase_mm is None or params.partner_wheelbase_tolerance <= 0 or paired:
        return wheels
    partners = _detect_wheels(roi_bgr, mask, offset_px, road_to_image, camera_foot_mm, replace(
        params, min_ellipse_overlap=params.partner_min_ellipse_overlap, min_dark_tyre=params.partner_min_dark_tyre,
        min_score=params.partner_min_score,
        wheelbase_range_mm=around(wheelbase_mm, params.partner_wheelbase_tolerance)))
    return partners if partners is not None and len(partners.wheels) == 2 else wheels


def around(value: float, tolerance: float) -> tuple[float, float]:
    """The range within `tolerance` (a share) of `value`."""
    return (1.0 - tolerance) * value, (1.0 + tolerance) * value


def _detect_wheels(roi_bgr: np.ndarray, mask: np.ndarray, offset_px: np.ndarray, road_to_image: ProjectiveTransform,
                   camera_foot_mm: np.ndarray, params: WheelParams) -> Wheels | None:
    """`detect_wheels` under one set of tests, no model's wheelbase told."""
    mask = np.asarray(mask, dtype=bool)
    if not mask.any():
        return None
    offset = np.asarray(offset_px, dtype=float)
    foot = np.asarray(camera_foot_mm, dtype=float)
    vertical_vp = road_to_image.homogeneous(foot)[0]
    horizon = road_to_image.map_lines(np.array([0.0, 0.0, 1.0]))[0]
    grey = cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    colour = chroma(roi_bgr)

    def measured(outlines: list[np.ndarray], dark: np.ndarray) -> list[tuple]:
        return [wheel for roi_rim, overlap, level_dark in rim_fits(outlines, dark, params)
                if rim_chroma(roi_rim, colour, params.rim_outline_band_px) <= params.rim_max_chroma
                and (wheel := measure_wheel(Ellipse(roi_rim.centre_px + offset, roi_rim.semi_axes_px, roi_rim.angle_deg),
                                           overlap, level_dark, grey, mask, offset, vertical_vp, horizon, road_to_image,
                                           params))]

    levels = dark_levels(grey, mask, params)
    from_holes = [measured(holes, dark) for dark, holes in levels]
    wheels = paired_wheels(best_per_place([wheel for level in from_holes for wheel in level]), road_to_image, foot, params)
    if params.spoked_rims and (wheels is None or len(wheels.wheels) < 2):
        spoked = paired_wheels(best_per_place([
            wheel for found, (dark, holes) in zip(from_holes, levels)
            for wheel in found + measured(spoked_rims(holes, dark.shape, params.min_rim_px), dark)
        ]), road_to_image, foot, params)
        if spoked is not None and (wheels is None or len(spoked.wheels) > len(wheels.wheels)):
            wheels = spoked
    return wheels


def paired_wheels(found: list[tuple], road_to_image: ProjectiveTransform, foot: np.ndarray,
                  params: WheelParams) -> Wheels | None:
    """Of the measured wheels (one per place), the best pair a wheelbase apart (or a lone wheel not of the nominal
    tyre), each with its tyre's contact half a tyre width inside its outer face; None when there is none."""
    if not found:
        return None
    outer_mm = road_to_image.inverse(np.array([item[2] for item in found]))
    planes_mm = np.array([np.linalg.solve(road_to_image.matrix, item[5])[:2] for item in found])
    keep = wheel_pair(outer_mm, planes_mm, np.array([item[0] for item in found]), params)
    keep = sorted(keep, key=lambda i: found[i][2][0])
    if len(keep) == 1 and found[keep[0]][6]:
        return None  # a nominal tyre alone is too weak a sign of a wheel; with its pair it stands
    found, outer_mm, planes_mm = [found[i] for i in keep], outer_mm[keep], planes_mm[keep]
    wheels = []
    for (score, rim, outer_px, factor, line, _, _), outer_road, plane_mm in zip(found, outer_mm, planes_mm):
        # the wheels' plane on the road: through both outer contacts, or towards its vanishing point
        along = outer_mm[-1] - outer_mm[0] if len(found) == 2 else plane_mm
        inward = np.array([-along[1], along[0]]) / np.linalg.norm(along)
        inward = inward if inward @ (outer_road - foot) > 0 else -inward
        contact = road_to_image(outer_road + params.tyre_width_mm / 2 * inward)[0]
        wheels.append(Wheel(rim, rim.scaled(factor), outer_px, contact, line, score))
    q_px = None
    if len(wheels) == 2:
        contacts_mm = road_to_image.inverse(np.array([wheel.contact_px for wheel in wheels]))
        q_px = road_to_image(contacts_mm.mean(axis=0, keepdims=True))[0]
    return Wheels(tuple(wheels), q_px, float(np.mean([wheel.score for wheel in wheels])))
