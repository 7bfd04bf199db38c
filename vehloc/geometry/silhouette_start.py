"""Where the model fit starts when neither plate nor wheels are found on a stopped vehicle: headings from the
silhouette itself. Its lower outline (the lowest vehicle pixel of each column, the vehicle's contact with the
road and its shadow line) mapped to the road runs along the footprint's near sides; its principal direction
is the length axis of a vehicle seen side-on, the width axis of one seen end-on, and between the two for one
seen at a quarter, so the fit starts from that direction and from its perpendicular."""

from __future__ import annotations

import numpy as np

from vehloc.geometry.placement import heading_of
from vehloc.geometry.projective import ProjectiveTransform

MIN_OUTLINE_POINTS = 3


def lower_outline_px(mask: np.ndarray, offset_px: np.ndarray) -> np.ndarray:
    """(N, 2) frame pixels: the bottom of the lowest vehicle pixel of each column of `mask` that has one."""
    columns = np.flatnonzero(mask.any(axis=0))
    lowest = mask.shape[0] - np.argmax(mask[::-1, columns], axis=0)
    return np.column_stack([columns + 0.5, lowest]).astype(float) + np.asarray(offset_px, dtype=float)


def principal_road_heading_deg(points_mm: np.ndarray) -> float | None:
    """The principal axis (deg, [0, 180)) of road points, None for fewer than three finite ones or no spread."""
    points = points_mm[np.all(np.isfinite(points_mm), axis=1)]
    if len(points) < MIN_OUTLINE_POINTS:
        return None
    centred = points - points.mean(axis=0)
    values, vectors = np.linalg.eigh(centred.T @ centred)
    if values[-1] <= 0.0:
        return None
    return heading_of(vectors[:, -1]) % 180.0


def silhouette_start_headings_deg(mask: np.ndarray, offset_px: np.ndarray, road_to_image: ProjectiveTransform
                                  ) -> tuple[float, ...]:
    """The headings (deg) the fit starts from: the principal road direction of the silhouette's lower outline
    and its perpendicular; none when the outline tells no direction."""
    if not mask.any():
        return ()
    heading = principal_road_heading_deg(road_to_image.inverse(lower_outline_px(mask, offset_px)))
    return () if heading is None else (heading, (heading + 90.0) % 180.0)
