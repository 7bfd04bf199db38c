"""Edges of painted road markings located around their image predicted by a homography, and the
refinement of that homography on them.

Each observation pairs a world line on the road (mm) with sub-pixel image points found on its
image: paint edges are the half-way crossings between paint and asphalt along intensity profiles.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vehloc.geometry.camera_fit import FreeHomography, PinholeHomography
from vehloc.geometry.projective import ProjectiveTransform

EdgeObservation = tuple[np.ndarray, np.ndarray]
"""A world line (a, b, c) on the road (mm) and the image points (N, 2) px observed on its image."""


@dataclass(frozen=True)
class EdgeSearchParams:
    """How far and how finely edges are searched around their predicted image (set in
    `conf/calibrate/calibration_params/default.yaml`, under `edge_search`)."""

    search_px: float
    min_contrast: float
    samples_per_stripe: int
    px_per_sample: float
    border_px: int


def world_line(start_mm: np.ndarray, end_mm: np.ndarray) -> np.ndarray:
    """Homogeneous road line through two points."""
    return np.cross([*start_mm, 1.0], [*end_mm, 1.0])


def _profile(grey: np.ndarray, centre_px: np.ndarray, direction: np.ndarray, reach_px: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.ndimage import map_coordinates  # scipy on first use: a refused CLI answers sooner
    offsets = np.linspace(-reach_px, reach_px, max(15, int(8 * reach_px)))
    samples = centre_px + offsets[:, None] * direction
    return offsets, map_coordinates(grey, [samples[:, 1], samples[:, 0]], order=1, mode="nearest")


def _crossing(offsets: np.ndarray, profile: np.ndarray, start: int, step: int, level: float) -> float | None:
    """Offset where the profile, walking from `start` by `step`, first falls below `level`."""
    i = start
    while 0 <= i + step < len(profile) and profile[i + step] >= level:
        i += step
    if not 0 <= i + step < len(profile):
        return None
    fraction = (profile[i] - level) / (profile[i] - profile[i + step])
    return float(offsets[i] + fraction * (offsets[i + step] - offsets[i]))


def _in_view(points_px: np.ndarray, shape: tuple[int, int], border_px: int) -> bool:
    height_px, width_px = shape
    return bool(
        np.all(np.isfinite(points_px))
        and np.all((points_px[:, 0] >= border_px) & (points_px[:, 0] < width_px - border_px))
        and np.all((points_px[:, 1] >= border_px) & (points_px[:, 1] < height_px - border_px))
    )


def stripe_edges(
    grey: np.ndarray,
    road_to_image: ProjectiveTransform,
    start_mm: np.ndarray,
    end_mm: np.ndarray,
    width_mm: float,
    params: EdgeSearchParams,
    span: tuple[float, float] = (0.0, 1.0),
) -> list[EdgeObservation]:
    """The two long edges of a painted band (centre line start -> end, width), over part `span` of it.

    Across the predicted band, the paint is the brightest run near the middle; its two half-way
    crossings are edge points of the left and right world edge lines."""
    start, end = np.asarray(start_mm, float), np.asarray(end_mm, float)
    along = (end - start) / np.linalg.norm(end - start)
    normal = np.array([-along[1], along[0]])
    half_mm = width_mm / 2
    fractions = np.linspace(span[0], span[1], params.samples_per_stripe)
    span_ends = road_to_image.map(start + np.array(span)[:, None] * (end - start))
    if span_ends.all_visible:
        span_px = span_ends.points
        samples = int(np.clip(np.linalg.norm(span_px[1] - span_px[0]) / params.px_per_sample, 3, params.samples_per_stripe))
        fractions = np.linspace(span[0], span[1], samples)
    sides: dict[int, list[np.ndarray]] = {-1: [], 1: []}
    for centre_mm in start + fractions[:, None] * (end - start):
        mapped = road_to_image.map(np.array([centre_mm, centre_mm + 100 * along, centre_mm + half_mm * normal]))
        if not mapped.all_visible:
            continue
        centre_px, ahead_px, side_px = mapped.points
        if not _in_view(np.array([centre_px]), grey.shape, params.border_px):
            continue
        direction = (ahead_px - centre_px) / np.linalg.norm(ahead_px - centre_px)
        across = np.array([-direction[1], direction[0]])
        half_px = abs((side_px - centre_px) @ across)
        offsets, profile = _profile(grey, centre_px, across, half_px + params.search_px)
        middle = np.abs(offsets) <= half_px + 1.0
        peak = int(np.flatnonzero(middle)[np.argmax(profile[middle])])
        outer = np.abs(offsets) >= half_px + 0.5 * params.search_px
        asphalt = float(np.median(profile[outer])) if outer.any() else float(profile.min())
        if profile[peak] - asphalt < params.min_contrast:
            continue
        level = 0.5 * (profile[peak] + asphalt)
        world_side = 1 if (side_px - centre_px) @ across > 0 else -1
        for step in (-1, 1):
            offset = _crossing(offsets, profile, peak, step, level)
            if offset is not None:
                sides[step * world_side].append(centre_px + offset * across)
    return [
        (world_line(start + side * half_mm * normal, end + side * half_mm * normal), np.array(points))
        for side, points in sides.items()
        if len(points) >= 3
    ]


def end_edges(
    grey: np.ndarray, road_to_image: ProjectiveTransform, start_mm: np.ndarray, end_mm: np.ndarray, width_mm: float,
    params: EdgeSearchParams,
) -> list[EdgeObservation]:
    """The two short ends of a painted band: where the paint stops along its centre line."""
    start, end = np.asarray(start_mm, float), np.asarray(end_mm, float)
    along = (end - start) / np.linalg.norm(end - start)
    normal = np.array([-along[1], along[0]]) * width_mm / 2
    observations = []
    for tip, inward in ((start, along), (end, -along)):
        mapped = road_to_image.map(np.array([tip, tip + 200 * inward]))
        if not mapped.all_visible:
            continue
        tip_px, inside_px = mapped.points
        if not _in_view(np.array([tip_px, inside_px]), grey.shape, params.border_px):
            continue
        outward = (tip_px - inside_px) / np.linalg.norm(tip_px - inside_px)
        offsets, profile = _profile(grey, tip_px, outward, params.search_px + 2.0)
        inner = offsets <= -1.0
        peak = int(np.flatnonzero(inner)[np.argmax(profile[inner])])
        asphalt = float(np.median(profile[offsets >= 0.5 * params.search_px]))
        if profile[peak] - asphalt < params.min_contrast:
            continue
        offset = _crossing(offsets, profile, peak, 1, 0.5 * (profile[peak] + asphalt))
        if offset is not None:
            observations.append((world_line(tip - normal, tip + normal), (tip_px + offset * outward)[None]))
    return observations


@dataclass(frozen=True)
class Anchors:
    """Approximate correspondences (world mm -> image px) with their uncertainty, as a weak prior."""

    world_mm: np.ndarray
    image_px: np.ndarray
    sigma_px: float


def refine_on_edges(
    road_to_image: ProjectiveTransform,
    edges: Sequence[EdgeObservation],
    robust_scale_px: float = 0.3,
    anchors: Anchors | None = None,
    model: FreeHomography | PinholeHomography | None = None,
) -> tuple[ProjectiveTransform, float | None]:
    """Refine H so that every observed edge point lies on the image of its world line.

    Edge points along whole sides constrain H far better than corners, whose positions are blurred
    where two edges meet. Anchors, when given, keep H near approximate correspondences in the
    directions the edges leave free (an anchor off by its sigma weighs like one edge point off by
    the robust scale). `model` parametrises H (free by default, or a pinhole camera). Returns the
    refined transform and the median absolute edge distance (px)."""
    from scipy.optimize import least_squares  # scipy on first use: a refused CLI answers sooner
    if not edges:
        return road_to_image, None
    world_lines = np.concatenate([np.repeat(line[None], len(points), 0) for line, points in edges])
    points = np.concatenate([points for _, points in edges])
    points_h = np.column_stack([points, np.ones(len(points))])

    model = model or FreeHomography()
    front_sign = model.front_sign(road_to_image)

    def edge_residuals(candidate: ProjectiveTransform) -> np.ndarray:
        image_lines = candidate.map_lines(world_lines)
        return np.sum(image_lines * points_h, axis=1) / np.hypot(image_lines[:, 0], image_lines[:, 1])

    def residuals(params: np.ndarray) -> np.ndarray:
        candidate = ProjectiveTransform(model.to_homography(params), front_sign)
        if anchors is None:
            return edge_residuals(candidate)
        anchor_px = candidate(anchors.world_mm) - anchors.image_px
        weight = robust_scale_px / anchors.sigma_px
        return np.concatenate([edge_residuals(candidate), weight * anchor_px.ravel()])

    if anchors is not None:
        road_to_image.map_visible(anchors.world_mm, "anchor")
    result = least_squares(
        residuals, model.from_homography(road_to_image), loss="soft_l1", f_scale=robust_scale_px, x_scale="jac"
    )
    refined = ProjectiveTransform(model.to_homography(result.x), front_sign)
    return refined, float(np.median(np.abs(edge_residuals(refined))))
