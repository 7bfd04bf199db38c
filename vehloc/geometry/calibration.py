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
from scipy.ndimage import map_coordinates
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.markers import DetectedMarker
from vehloc.geometry.site import Site, SiteError, SiteStripe, collinearity_ratio


class CalibrationError(SiteError):
    """Calibration cannot be done from this image and site (too few or degenerate matches)."""


@dataclass(frozen=True)
class CalibrationParams:
    """Gates and thresholds of the matching loop, in image pixels."""

    initial_gate_px: float = 40.0
    final_gate_px: float = 6.0
    ransac_threshold_px: float = 2.0
    max_iterations: int = 10
    min_matches: int = 4
    refine_on_edges: bool = True
    stripe_search_px: float = 4.0
    stripe_min_contrast: float = 20.0
    stripe_rounds: int = 2


@dataclass(frozen=True)
class Calibration:
    """A road-plane homography (world mm -> image px) and how well it fits the matched corners."""

    homography: np.ndarray
    world_mm: np.ndarray
    image_px: np.ndarray
    labels: tuple[str, ...]
    inliers: np.ndarray
    iterations: int
    median_edge_px: float | None = None

    def road_to_image(self, points_mm: np.ndarray) -> np.ndarray:
        """Road points (N, 2) mm -> pixels (N, 2)."""
        return apply_homography(self.homography, points_mm)

    def image_to_road(self, points_px: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) -> road points (N, 2) mm."""
        return apply_homography(np.linalg.inv(self.homography), points_px)

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


def apply_homography(homography: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Map (N, 2) points through a 3x3 homography."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    mapped = np.column_stack([points, np.ones(len(points))]) @ np.asarray(homography).T
    return mapped[:, :2] / mapped[:, 2:3]


def unambiguous_gates_px(projected_px: np.ndarray, gate_px: float, fraction: float = 0.4) -> np.ndarray:
    """Per-point gate: at most `fraction` of the distance to the nearest other projected point, so that
    a rough estimate cannot pair a marker with its periodic neighbour (the next dash along the road)."""
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
    homography: np.ndarray, surveyed_quads_mm: np.ndarray, detected_quads_px: np.ndarray, gate_px: float
) -> list[MarkerMatch]:
    """Markers paired by their centroids, with their corners paired in cyclic order."""
    projected = apply_homography(homography, surveyed_quads_mm.reshape(-1, 2)).reshape(-1, 4, 2)
    centroids = projected.mean(axis=1)
    pairs = match_points(centroids, detected_quads_px.mean(axis=1), unambiguous_gates_px(centroids, gate_px))
    return [
        MarkerMatch(surveyed, detected, pair_corners(projected[surveyed], detected_quads_px[detected]))
        for surveyed, detected in sorted(pairs)
    ]


EdgeObservation = tuple[np.ndarray, np.ndarray]
"""A world line (a, b, c) on the road (mm) and the image points (N, 2) px observed on its image."""


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


def stripe_edges(
    grey: np.ndarray, homography: np.ndarray, stripe: SiteStripe, params: CalibrationParams
) -> list[EdgeObservation]:
    """Edge points of a solid painted stripe, searched across its image predicted by H.

    Along the stripe, an intensity profile is taken across its predicted image; the paint is the
    brightest run near the middle and each of its two half-way crossings is an edge point."""
    start, end = np.asarray(stripe.start_mm, float), np.asarray(stripe.end_mm, float)
    along = (end - start) / np.linalg.norm(end - start)
    normal = np.array([-along[1], along[0]])
    half_mm = stripe.width_mm / 2
    centres_mm = start + np.linspace(0, 1, 400)[:, None] * (end - start)
    height_px, width_px = grey.shape
    inverse = np.linalg.inv(homography)
    sides: dict[int, list[np.ndarray]] = {-1: [], 1: []}
    for centre_mm in centres_mm:
        centre_px, ahead_px, side_px = apply_homography(
            homography, np.array([centre_mm, centre_mm + 100 * along, centre_mm + half_mm * normal])
        )
        if not (np.all(np.isfinite([centre_px, ahead_px, side_px])) and 6 <= centre_px[0] < width_px - 6
                and 6 <= centre_px[1] < height_px - 6):
            continue
        if (inverse @ [*centre_px, 1.0])[2] * (homography @ [*centre_mm, 1.0])[2] <= 0:
            continue
        direction = (ahead_px - centre_px) / np.linalg.norm(ahead_px - centre_px)
        across = np.array([-direction[1], direction[0]])
        half_px = abs((side_px - centre_px) @ across)
        reach_px = half_px + params.stripe_search_px
        offsets = np.linspace(-reach_px, reach_px, max(15, int(8 * reach_px)))
        samples = centre_px + offsets[:, None] * across
        profile = map_coordinates(grey, [samples[:, 1], samples[:, 0]], order=1, mode="nearest")
        middle = np.abs(offsets) <= half_px + 1.0
        peak = int(np.flatnonzero(middle)[np.argmax(profile[middle])])
        outer = np.abs(offsets) >= half_px + 0.5 * params.stripe_search_px
        asphalt = float(np.median(profile[outer])) if outer.any() else float(profile.min())
        if profile[peak] - asphalt < params.stripe_min_contrast:
            continue
        half_level = 0.5 * (profile[peak] + asphalt)
        sign_of_world_side = 1 if (side_px - centre_px) @ across > 0 else -1
        for step in (-1, 1):
            i = peak
            while 0 <= i + step < len(profile) and profile[i + step] >= half_level:
                i += step
            if not 0 <= i + step < len(profile):
                continue
            fraction = (profile[i] - half_level) / (profile[i] - profile[i + step])
            offset = offsets[i] + fraction * (offsets[i + step] - offsets[i])
            sides[step * sign_of_world_side].append(centre_px + offset * across)
    edges = []
    for side, points in sides.items():
        if len(points) >= 3:
            edge_start, edge_end = start + side * half_mm * normal, end + side * half_mm * normal
            edges.append((np.cross([*edge_start, 1.0], [*edge_end, 1.0]), np.array(points)))
    return edges


def refine_on_edges(
    homography: np.ndarray, edges: Sequence[EdgeObservation], robust_scale_px: float = 0.3
) -> tuple[np.ndarray, float | None]:
    """Refine H so that every observed edge point lies on the image of its world line.

    Edge points along whole sides constrain H far better than corners, whose positions are blurred
    where two edges meet. Returns the refined H and the median absolute edge distance (px)."""
    if not edges:
        return homography, None
    world_lines = np.concatenate([np.repeat(line[None], len(points), 0) for line, points in edges])
    points = np.concatenate([points for _, points in edges])
    points_h = np.column_stack([points, np.ones(len(points))])

    def residuals(params: np.ndarray) -> np.ndarray:
        candidate = np.append(params, 1.0).reshape(3, 3)
        image_lines = world_lines @ np.linalg.inv(candidate)  # rows: H^-T applied to each world line
        return np.sum(image_lines * points_h, axis=1) / np.hypot(image_lines[:, 0], image_lines[:, 1])

    start = (homography / homography[2, 2]).ravel()[:8]
    result = least_squares(residuals, start, loss="soft_l1", f_scale=robust_scale_px, x_scale="jac")
    return np.append(result.x, 1.0).reshape(3, 3), float(np.median(np.abs(result.fun)))


def _estimate(world_mm: np.ndarray, image_px: np.ndarray, params: CalibrationParams) -> tuple[np.ndarray, np.ndarray]:
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
    return homography / homography[2, 2], mask.ravel().astype(bool)


def calibrate(
    detected: Sequence[DetectedMarker],
    site: Site,
    params: CalibrationParams | None = None,
    image_bgr: np.ndarray | None = None,
) -> Calibration:
    """Estimate the road homography from detected markers and a site description.

    With the image, the site's solid stripes (edge lines) are searched for and join the refinement."""
    params = params or CalibrationParams()
    surveyed = [m for m in site.markers if len(m.corners_mm) == 4]
    if not surveyed:
        raise CalibrationError(f"site {site.name!r} has no marker with four surveyed corners")
    surveyed_quads = np.stack([m.corners_mm for m in surveyed])
    detected_quads = np.array([m.corners_px for m in detected], dtype=float).reshape(-1, 4, 2)
    homography = site.initial_homography
    gate_px = params.initial_gate_px
    previous: list[tuple[int, int]] | None = None
    for iteration in range(1, params.max_iterations + 1):
        matches = match_markers(homography, surveyed_quads, detected_quads, gate_px)
        world = np.array([surveyed_quads[m.surveyed, k] for m in matches for k in range(4)]).reshape(-1, 2)
        image = np.array([detected_quads[m.detected, m.order[k]] for m in matches for k in range(4)]).reshape(-1, 2)
        homography, inliers = _estimate(world, image, params)
        pairs = [(m.surveyed, m.detected) for m in matches]
        if pairs == previous:
            break
        previous = pairs
        gate_px = max(params.final_gate_px, 0.5 * gate_px)
    edge_px = None
    if params.refine_on_edges:
        edges = marker_edges(surveyed_quads, detected, matches)
        homography, edge_px = refine_on_edges(homography, edges)
        if site.stripes and image_bgr is not None:
            grey = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
            for _ in range(params.stripe_rounds):
                found = [e for stripe in site.stripes for e in stripe_edges(grey, homography, stripe, params)]
                homography, edge_px = refine_on_edges(homography, edges + found)
    labels = tuple(f"{surveyed[m.surveyed].marker_id}:{k}" for m in matches for k in range(4))
    return Calibration(homography, world, image, labels, inliers, iteration, edge_px)


@dataclass(frozen=True)
class CameraFromHomography:
    """Camera recovered from a road homography with a known principal point."""

    camera: PinholeCamera
    focal_px: float
    height_mm: float
    tilt_deg: float


def camera_from_homography(
    homography: np.ndarray, width_px: int, height_px: int, principal_px: tuple[float, float] | None = None
) -> CameraFromHomography:
    """Recover focal length, pose, height and downward tilt from H = K [r1 r2 t] (square pixels)."""
    cx, cy = principal_px if principal_px is not None else ((width_px - 1) / 2, (height_px - 1) / 2)
    centred = np.array([[1, 0, -cx], [0, 1, -cy], [0, 0, 1.0]]) @ np.asarray(homography, dtype=float)
    h1, h2, h3 = centred[:, 0], centred[:, 1], centred[:, 2]
    # r1 . r2 = 0 and |r1| = |r2| give two linear equations in 1/f^2 (unknown) and 1 (known).
    rows = np.array([[h1[0] * h2[0] + h1[1] * h2[1], h1[2] * h2[2]],
                     [h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2, h1[2] ** 2 - h2[2] ** 2]])
    inv_f2 = -float(rows[:, 1] @ rows[:, 0]) / float(rows[:, 0] @ rows[:, 0])
    if not inv_f2 > 0:
        raise CalibrationError("the homography gives no real focal length (image plane parallel to the road?)")
    focal_px = 1.0 / np.sqrt(inv_f2)
    K = PinholeCamera.intrinsics(focal_px, width_px, height_px, (cx, cy))
    K_inv = np.linalg.inv(K)
    homography = np.asarray(homography, dtype=float)
    r1, r2, t = (K_inv @ homography[:, i] for i in range(3))
    scale = 2.0 / (np.linalg.norm(r1) + np.linalg.norm(r2))
    road_below_centre = np.linalg.solve(homography, [cx, height_px - 1.0, 1.0])
    depth_sign = np.sign((homography @ (road_below_centre / road_below_centre[2]))[2])
    scale *= depth_sign  # road points seen at the image bottom lie in front of the camera
    r1, r2, t = r1 * scale, r2 * scale, t * scale
    u, _, vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = u @ vt
    if np.linalg.det(R) < 0:
        R = u @ np.diag([1, 1, -1]) @ vt
    camera = PinholeCamera(K=K, R=R, t=t, width_px=width_px, height_px=height_px)
    forward = R[2]
    tilt_deg = float(np.degrees(np.arcsin(np.clip(-forward[2], -1, 1))))
    return CameraFromHomography(camera, float(focal_px), float(camera.centre_mm[2]), tilt_deg)
