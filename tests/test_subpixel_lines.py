"""Segments moved onto their edge's sub-pixel position, against edges drawn at exact sub-pixel lines."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vehloc.geometry.subpixel_lines import refined_segment_px, refined_segments_px

SUPERSAMPLE = 16


def edge_image(row_at_left_px: float, row_at_right_px: float, width_px: int = 80, height_px: int = 30,
               noise_sigma: float = 0.0, seed: int = 0) -> np.ndarray:
    """A light body (above) on a dark road (below) whose boundary runs straight from (0, `row_at_left_px`) to
    (`width_px`, `row_at_right_px`) (pixel edges' coordinates), each pixel the mix of the two it covers (drawn
    16 times finer and averaged), with Gaussian sensor noise."""
    fine_rows = (np.arange(height_px * SUPERSAMPLE) + 0.5) / SUPERSAMPLE
    fine_cols = (np.arange(width_px * SUPERSAMPLE) + 0.5) / SUPERSAMPLE
    boundary = row_at_left_px + (row_at_right_px - row_at_left_px) * fine_cols / width_px
    body = fine_rows[:, None] < boundary[None, :]
    light, dark = np.array([200.0, 190.0, 180.0]), np.array([70.0, 75.0, 80.0])
    fine = np.where(body[..., None], light, dark).astype(np.float32)
    image = cv2.resize(fine, (width_px, height_px), interpolation=cv2.INTER_AREA)
    image += np.random.default_rng(seed).normal(0.0, noise_sigma, image.shape)
    return np.clip(image.round(), 0, 255).astype(np.uint8)


def row_on(segment: np.ndarray, x_px: float) -> float:
    """The segment's line's row (pixel-centre coordinates) at column `x_px` (pixel-centre coordinates)."""
    x1, y1, x2, y2 = segment
    return y1 + (y2 - y1) * (x_px - x1) / (x2 - x1)


@pytest.mark.parametrize("noise_sigma", [0.0, 2.0])
def test_a_level_hough_segment_takes_the_edges_sub_pixel_slope(noise_sigma: float) -> None:
    """An edge sloping 0.8 px over 80 px, given as a level segment on whole pixels (as Hough gives it): the refined
    line is the edge's within 0.05 px at both ends (0.1 px with sensor noise of 2 grey levels)."""
    image = edge_image(12.3, 13.1, noise_sigma=noise_sigma)
    refined = refined_segment_px(image, np.array([3.0, 12.0, 76.0, 12.0]), 2.0)
    for x_px in (3.0, 76.0):
        true_row = 12.3 + 0.8 * (x_px + 0.5) / 80 - 0.5  # pixel-edge to pixel-centre coordinates
        assert row_on(refined, x_px) == pytest.approx(true_row, abs=0.05 if noise_sigma == 0 else 0.1)


def test_a_segment_too_short_or_without_an_edge_stays_as_it_was() -> None:
    """A segment with fewer sub-pixel peaks than it needs (too short, or on a flat colour) is given back unchanged,
    and a reach of 0 leaves every segment as it is."""
    image = edge_image(12.3, 13.1)
    short = np.array([10.0, 12.0, 14.0, 12.0])
    assert np.array_equal(refined_segment_px(image, short, 2.0), short)
    flat = np.full((30, 80, 3), 128, np.uint8)
    level = np.array([3.0, 12.0, 76.0, 12.0])
    assert np.array_equal(refined_segment_px(flat, level, 2.0), level)
    segments = np.array([level, short])
    assert np.array_equal(refined_segments_px(image, segments, 0.0), segments)
