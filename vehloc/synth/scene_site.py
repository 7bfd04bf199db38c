"""The site file of a rendered scene: its surveyed markers and four corners 'clicked' in the image."""

from __future__ import annotations

import numpy as np

from vehloc.geometry.site import Site, SiteMarker, SiteStripe, homography_from_points
from vehloc.synth.scene import SceneSpec


def _visible(pixels: np.ndarray, width_px: int, height_px: int, margin_px: float) -> np.ndarray:
    inside = np.all(np.isfinite(pixels), axis=1)
    inside &= (pixels[:, 0] >= margin_px) & (pixels[:, 0] < width_px - margin_px)
    return inside & (pixels[:, 1] >= margin_px) & (pixels[:, 1] < height_px - margin_px)


def scene_site(spec: SceneSpec, click_noise_px: float = 2.0, seed: int = 0) -> Site:
    """Surveyed marker corners and edge-line stripes of the scene's road, and an initial guess from
    four visible corners spread over the image (nearest and farthest, left and right), perturbed
    like hand clicks."""
    camera = spec.camera.camera()
    markers = tuple(SiteMarker(m.marker_id, m.corners_mm) for m in spec.layout.markers() if m.has_corners)
    if not markers:
        raise ValueError(f"scene {spec.name}: the road has no marker with corners")
    corners = np.concatenate([m.corners_mm for m in markers])
    pixels = camera.project(np.column_stack([corners, np.zeros(len(corners))]))
    visible = np.flatnonzero(_visible(pixels, camera.width_px, camera.height_px, margin_px=20))
    if len(visible) < 4:
        raise ValueError(f"scene {spec.name}: fewer than 4 marker corners are visible")
    near = visible[np.argsort(-pixels[visible, 1])[: max(4, len(visible) // 3)]]
    far = visible[np.argsort(pixels[visible, 1])[: max(4, len(visible) // 3)]]
    chosen = [
        near[np.argmin(pixels[near, 0])], near[np.argmax(pixels[near, 0])],
        far[np.argmax(pixels[far, 0])], far[np.argmin(pixels[far, 0])],
    ]
    rng = np.random.default_rng(seed)
    clicked_px = np.round(pixels[chosen] + rng.normal(0.0, click_noise_px, (4, 2)), 1)
    world = corners[chosen]
    guess = homography_from_points(world, clicked_px, f"scene {spec.name}: clicked corners")
    points = tuple(((float(w[0]), float(w[1])), (float(p[0]), float(p[1]))) for w, p in zip(world, clicked_px))
    stripes = tuple(
        SiteStripe(
            m.marker_id,
            tuple((m.corners_mm[0] + m.corners_mm[1]) / 2),
            tuple((m.corners_mm[2] + m.corners_mm[3]) / 2),
            float(np.linalg.norm(m.corners_mm[1] - m.corners_mm[0])),
        )
        for m in spec.layout.markers()
        if not m.has_corners
    )
    return Site(spec.name, markers, guess / guess[2, 2], (camera.width_px, camera.height_px), points, stripes)
