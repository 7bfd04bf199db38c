"""Camera calibration from lane markers: match detected corners to surveyed ones, RANSAC homography.

Starting from the site's rough homography, surveyed corners are projected into the image and paired
with detected corners (mutual nearest neighbours inside a gate); RANSAC estimates the homography from
the pairs, and matching is repeated with the refined estimate and a tighter gate until the matched
set stops changing.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import params_from_config
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_fit import FreeHomography, PinholeHomography
from vehloc.geometry.edges import (
    Anchors,
    EdgeObservation,
    EdgeSearchParams,
    end_edges,
    refine_on_edges,
    stripe_edges,
)
from vehloc.geometry.markers import DetectedMarker
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.site import Site, SiteError, collinearity_ratio


def image_size_of(image: np.ndarray) -> tuple[int, int]:
    """(width, height) in pixels of an image array."""
    return int(image.shape[1]), int(image.shape[0])


class CalibrationError(SiteError):
    """Calibration cannot be done from this image and site (too few or degenerate matches)."""


@dataclass(frozen=True)
class CalibrationParams:
    """Gates and thresholds of the matching loop, in image pixels."""

    initial_gate_px: float
    final_gate_px: float
    ransac_threshold_px: float
    max_iterations: int
    min_matches: int
    refine_on_edges: bool
    refine_rounds: int
    guess_sigma_px: float
    pinhole_model: bool
    edge_search: EdgeSearchParams

    @classmethod
    def from_config(cls, **overrides: object) -> CalibrationParams:
        """The settings of `conf/calibrate/calibration_params/default.yaml`, with `overrides`."""
        return params_from_config(cls, "calibrate/calibration_params/default.yaml", overrides)


@dataclass(frozen=True)
class Calibration:
    """A road-plane homography (world mm -> image px) and how well it fits the matched corners."""

    transform: ProjectiveTransform
    world_mm: np.ndarray
    image_px: np.ndarray
    labels: tuple[str, ...]
    inliers: np.ndarray
    iterations: int
    median_edge_px: float | None = None

    @property
    def homography(self) -> np.ndarray:
        """H (world mm -> image px) scaled to h33 = 1."""
        return self.transform.normalised_matrix

    def road_to_image(self, points_mm: np.ndarray) -> np.ndarray:
        """Road points (N, 2) mm -> pixels (N, 2); NaN beyond the horizon."""
        return self.transform(points_mm)

    def image_to_road(self, points_px: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) -> road points (N, 2) mm; NaN at or above the horizon."""
        return self.transform.inverse(points_px)

    @property
    def inlier_count(self) -> int:
        return int(self.inliers.sum())

    @property
    def rms_reprojection_px(self) -> float:
        """RMS distance between detected inlier corners and their surveyed corners projected by H."""
        residual = self.road_to_image(self.world_mm[self.inliers]) - self.image_px[self.inliers]
        return float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))

    @property
    def rms_road_error_mm(self) -> float:
        """RMS distance on the road between back-projected inlier corners and their surveyed positions."""
        residual = self.image_to_road(self.image_px[self.inliers]) - self.world_mm[self.inliers]
        return float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))

    def summary(self) -> dict[str, object]:
        return {
            "homography_world_mm_to_image_px": self.homography.tolist(),
            "matched_corners": len(self.labels),
            "inliers": self.inlier_count,
            "rms_reprojection_px": self.rms_reprojection_px,
            "rms_road_error_mm": self.rms_road_error_mm,
            "median_edge_px": self.median_edge_px,
            "iterations": self.iterations,
        }


def unambiguous_gates_px(projected_px: np.ndarray, gate_px: float, fraction: float = 0.4) -> np.ndarray:
    """Per-point gate: at most `fraction` of the distance to the nearest other projected point, so that
    a rough estimate cannot pair a marker with its periodic neighbour (the next dash along the road)."""
    from scipy.spatial import cKDTree  # scipy on first use: a refused CLI answers sooner
    finite = np.all(np.isfinite(projected_px), axis=1)
    gates = np.full(len(projected_px), gate_px)
    if finite.sum() > 1:
        distance, _ = cKDTree(projected_px[finite]).query(projected_px[finite], k=2)
        gates[finite] = np.minimum(gate_px, fraction * distance[:, 1])
    return gates


def match_points(
    projected_px: np.ndarray, detected_px: np.ndarray, gate_px: float | np.ndarray
) -> list[tuple[int, int]]:
    """Mutual nearest-neighbour pairs (projected index, detected index) closer than the gate
    (one gate, or one per projected point)."""
    from scipy.spatial import cKDTree  # scipy on first use: a refused CLI answers sooner
    finite = np.all(np.isfinite(projected_px), axis=1)
    if not finite.any() or len(detected_px) == 0:
        return []
    projected_index = np.flatnonzero(finite)
    gates = np.broadcast_to(np.asarray(gate_px, dtype=float), (len(projected_px),))[finite]
    distance, nearest_projected = cKDTree(projected_px[finite]).query(detected_px)
    _, nearest_detected = cKDTree(detected_px).query(projected_px[finite])
    return [
        (int(projected_index[p]), detected)
        for detected, (d, p) in enumerate(zip(distance, nearest_projected))
        if d <= gates[p] and nearest_detected[p] == detected
    ]


def pair_corners(projected_quad_px: np.ndarray, detected_quad_px: np.ndarray) -> np.ndarray:
    """Index into the detected quad for each projected corner: the cyclic order (either direction)
    with the smallest total distance."""
    best_order, best_cost = np.arange(4), np.inf
    for direction in (1, -1):
        for shift in range(4):
            order = (shift + direction * np.arange(4)) % 4
            cost = np.linalg.norm(projected_quad_px - detected_quad_px[order], axis=1).sum()
            if cost < best_cost:
                best_order, best_cost = order, cost
    return best_order


@dataclass(frozen=True)
class MarkerMatch:
    """A surveyed marker paired with a detected one; `order[k]` is the detected corner of world corner k."""

    surveyed: int
    detected: int
    order: np.ndarray

    def detected_side(self, world_side: int) -> int:
        """Index of the detected side that images world side k (corner k to corner k + 1)."""
        start, end = int(self.order[world_side]), int(self.order[(world_side + 1) % 4])
        return start if (end - start) % 4 == 1 else end


def match_markers(
    road_to_image: ProjectiveTransform, surveyed_quads_mm: np.ndarray, detected_quads_px: np.ndarray, gate_px: float
) -> list[MarkerMatch]:
    """Markers paired by their centroids, with their corners paired in cyclic order."""
    projected = road_to_image(surveyed_quads_mm.reshape(-1, 2)).reshape(-1, 4, 2)
    centroids = projected.mean(axis=1)
    pairs = match_points(centroids, detected_quads_px.mean(axis=1), unambiguous_gates_px(centroids, gate_px))
    return [
        MarkerMatch(surveyed, detected, pair_corners(projected[surveyed], detected_quads_px[detected]))
        for surveyed, detected in sorted(pairs)
    ]


def marker_edges(
    surveyed_quads_mm: np.ndarray, markers: Sequence[DetectedMarker], matches: Sequence[MarkerMatch]
) -> list[EdgeObservation]:
    """The sub-pixel edge points of every matched marker side, with the world line of that side."""
    edges = []
    for match in matches:
        quad = surveyed_quads_mm[match.surveyed]
        sides = markers[match.detected].side_points_px
        for k in range(4):
            points = sides[match.detected_side(k)] if sides else np.zeros((0, 2))
            if len(points):
                edges.append((np.cross([*quad[k], 1.0], [*quad[(k + 1) % 4], 1.0]), points))
    return edges


def site_edges(
    grey: np.ndarray, road_to_image: ProjectiveTransform, site: Site, params: EdgeSearchParams
) -> list[EdgeObservation]:
    """Edges of every surveyed marker and stripe of the site, searched around their image under H."""
    edges = []
    for stripe in site.stripes:
        edges += stripe_edges(grey, road_to_image, stripe.start_mm, stripe.end_mm, stripe.width_mm, params)
    for marker in site.markers:
        if len(marker.corners_mm) != 4:
            continue
        c = marker.corners_mm
        start, end, width_mm = (c[0] + c[1]) / 2, (c[2] + c[3]) / 2, float(np.linalg.norm(c[1] - c[0]))
        edges += stripe_edges(grey, road_to_image, start, end, width_mm, params, span=(0.15, 0.85))
        edges += end_edges(grey, road_to_image, start, end, width_mm, params)
    return edges


def refine_on_site(
    image_bgr: np.ndarray, site: Site, road_to_image: ProjectiveTransform, params: CalibrationParams | None = None
) -> tuple[ProjectiveTransform, float | None]:
    """Refine H on the edges of the site's markers and stripes, searched around their predicted image;
    a few rounds, each searching around the previous estimate. The site's clicked points, when it
    has them, hold the estimate where no edge is seen (a prior of `guess_sigma_px`). Returns H and
    the median edge distance (px) of the last round. With `pinhole_model`, H stays the homography
    of a pinhole camera with square pixels and a centred principal point (7 parameters), which
    keeps a view with few markers physically consistent."""
    params = params or CalibrationParams.from_config()
    grey = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    anchors = None
    if site.guess_points:
        anchors = Anchors(
            np.array([w for w, _ in site.guess_points]), np.array([p for _, p in site.guess_points]), params.guess_sigma_px
        )
    model = PinholeHomography(grey.shape[1], grey.shape[0]) if params.pinhole_model else FreeHomography()
    edge_px = None
    for _ in range(params.refine_rounds):
        edges = site_edges(grey, road_to_image, site, params.edge_search)
        if not edges:
            break
        road_to_image, edge_px = refine_on_edges(road_to_image, edges, anchors=anchors, model=model)
    return road_to_image, edge_px


def _estimate(
    world_mm: np.ndarray, image_px: np.ndarray, params: CalibrationParams
) -> tuple[ProjectiveTransform, np.ndarray]:
    if len(world_mm) < params.min_matches:
        raise CalibrationError(
            f"only {len(world_mm)} detected marker corner(s) matched the site's surveyed corners; "
            f"at least {params.min_matches} are needed (check the site file's initial guess)"
        )
    if collinearity_ratio(world_mm) < 1e-3:
        raise CalibrationError(
            f"the {len(world_mm)} matched corners are collinear on the road; a homography needs corners off one line"
        )
    homography, mask = cv2.findHomography(world_mm, image_px, cv2.RANSAC, params.ransac_threshold_px)
    if homography is None or mask is None or int(mask.sum()) < params.min_matches:
        raise CalibrationError(
            f"RANSAC found no consensus among {len(world_mm)} matched corners "
            f"(threshold {params.ransac_threshold_px} px)"
        )
    inliers = mask.ravel().astype(bool)
    # the matched corners were seen: the visible side is theirs
    return ProjectiveTransform.seen_from(homography, image_px[np.flatnonzero(inliers)[0]]), inliers


def calibrate(
    detected: Sequence[DetectedMarker],
    site: Site,
    params: CalibrationParams | None = None,
    image_bgr: np.ndarray | None = None,
) -> Calibration:
    """Estimate the road homography from detected markers and a site description.

    With the image, the site's solid stripes (edge lines) are searched for and join the refinement."""
    params = params or CalibrationParams.from_config()
    surveyed = [m for m in site.markers if len(m.corners_mm) == 4]
    if not surveyed:
        raise CalibrationError(f"site {site.name!r} has no marker with four surveyed corners")
    surveyed_quads = np.stack([m.corners_mm for m in surveyed])
    detected_quads = np.array([m.corners_px for m in detected], dtype=float).reshape(-1, 4, 2)
    road_to_image = site.initial_transform(None if image_bgr is None else image_size_of(image_bgr))
    gate_px = params.initial_gate_px
    previous: list[tuple[int, int]] | None = None
    for iteration in range(1, params.max_iterations + 1):
        matches = match_markers(road_to_image, surveyed_quads, detected_quads, gate_px)
        world = np.array([surveyed_quads[m.surveyed, k] for m in matches for k in range(4)]).reshape(-1, 2)
        image = np.array([detected_quads[m.detected, m.order[k]] for m in matches for k in range(4)]).reshape(-1, 2)
        road_to_image, inliers = _estimate(world, image, params)
        pairs = [(m.surveyed, m.detected) for m in matches]
        if pairs == previous:
            break
        previous = pairs
        gate_px = max(params.final_gate_px, 0.5 * gate_px)
    edge_px = None
    if params.refine_on_edges:
        road_to_image, edge_px = refine_on_edges(road_to_image, marker_edges(surveyed_quads, detected, matches))
        if image_bgr is not None:
            road_to_image, edge_px = refine_on_site(image_bgr, site, road_to_image, params)
    labels = tuple(f"{surveyed[m.surveyed].marker_id}:{k}" for m in matches for k in range(4))
    return Calibration(road_to_image, world, image, labels, inliers, iteration, edge_px)


def calibrate_from_guess(
    image_bgr: np.ndarray, site: Site, params: CalibrationParams | None = None
) -> Calibration:
    """Refine the site's clicked guess on the edges of its predicted markers and stripes.

    For views whose markers are too small or blurred to be found as blobs. The clicked points serve
    as the matched corners of the result, so its reprojection error is theirs; CalibrationError when no edge is
    found to refine on (the guess would be returned unchanged, with an RMS of 0)."""
    params = params or CalibrationParams.from_config()
    if not site.guess_points:
        raise CalibrationError(f"site {site.name!r}: calibrating from the guess needs 'initial_guess.points'")
    road_to_image, edge_px = refine_on_site(image_bgr, site, site.initial_transform(), params)
    if edge_px is None:
        raise CalibrationError(
            f"site {site.name!r}: no edge of its markers or stripes is where the clicked guess puts them (an image "
            "of another place, or markers out of sight): a guess alone is no calibration")
    world = np.array([w for w, _ in site.guess_points])
    image = np.array([p for _, p in site.guess_points])
    labels = tuple(f"guess:{i}" for i in range(len(world)))
    return Calibration(road_to_image, world, image, labels, np.ones(len(world), bool), params.refine_rounds, edge_px)


@dataclass(frozen=True)
class CameraFromHomography:
    """Camera recovered from a road homography with a known principal point."""

    camera: PinholeCamera
    focal_px: float
    height_mm: float
    tilt_deg: float


def camera_from_homography(
    road_to_image: ProjectiveTransform, width_px: int, height_px: int, principal_px: tuple[float, float] | None = None
) -> CameraFromHomography:
    """Recover focal length, pose, height and downward tilt from H = K [r1 r2 t] (square pixels)."""
    cx, cy = principal_px if principal_px is not None else ((width_px - 1) / 2, (height_px - 1) / 2)
    homography = road_to_image.matrix
    centred = np.array([[1, 0, -cx], [0, 1, -cy], [0, 0, 1.0]]) @ homography
    h1, h2 = centred[:, 0], centred[:, 1]
    # r1 . r2 = 0 and |r1| = |r2| give two linear equations in 1/f^2 (unknown) and 1 (known).
    rows = np.array([[h1[0] * h2[0] + h1[1] * h2[1], h1[2] * h2[2]],
                     [h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2, h1[2] ** 2 - h2[2] ** 2]])
    inv_f2 = -float(rows[:, 1] @ rows[:, 0]) / float(rows[:, 0] @ rows[:, 0])
    if not inv_f2 > 0:
        raise CalibrationError("the homography gives no real focal length (image plane parallel to the road?)")
    focal_px = 1.0 / np.sqrt(inv_f2)
    K = PinholeCamera.intrinsics(focal_px, width_px, height_px, (cx, cy))
    K_inv = np.linalg.inv(K)
    r1, r2, t = (K_inv @ homography[:, i] for i in range(3))
    scale = 2.0 / (np.linalg.norm(r1) + np.linalg.norm(r2))
    scale *= road_to_image.front_sign  # w is the depth: positive for the road seen, in front of the camera
    r1, r2, t = r1 * scale, r2 * scale, t * scale
    u, _, vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = u @ vt
    if np.linalg.det(R) < 0:
        R = u @ np.diag([1, 1, -1]) @ vt
    camera = PinholeCamera(K=K, R=R, t=t, width_px=width_px, height_px=height_px)
    forward = R[2]
    tilt_deg = float(np.degrees(np.arcsin(np.clip(-forward[2], -1, 1))))
    return CameraFromHomography(camera, float(focal_px), float(camera.centre_mm[2]), tilt_deg)
