"""The background stage's mask operations work only around the foreground; their results must be those of the
same operations over the whole frame, exactly, wherever the blobs lie (the frame's edges included)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from vehloc.data.boxes import Box
from vehloc.config import ConfigError
from vehloc.geometry.roi import RoiParams, VehicleRoiExtractor, blob_boxes, clean_mask, occupied_box

PARAMS = RoiParams.from_config()


def _whole_frame_clean_mask(mask: np.ndarray) -> np.ndarray:
    """Open, close and fill over the whole frame: the reference."""
    opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((PARAMS.open_kernel_px,) * 2, np.uint8))
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (PARAMS.close_kernel_px,) * 2)
    closed = cv2.morphologyEx(opened, cv2.MORPH_CLOSE, kernel)
    contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    filled = np.zeros_like(closed)
    cv2.drawContours(filled, contours, -1, 255, cv2.FILLED)
    return filled


def _whole_frame_blob_boxes(mask: np.ndarray, min_area_px: int) -> list[Box]:
    count, _, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    boxes = [(area, Box(int(x), int(y), int(x + w), int(y + h))) for x, y, w, h, area in stats[1:count]
             if area >= min_area_px]
    return [box for _, box in sorted(boxes, key=lambda item: -item[0])]


def _blobby_mask(seed: int) -> np.ndarray:
    """A half-size frame's foreground: a few ragged blobs with holes and gaps (some cut by the frame's edge)
    and speckle everywhere."""
    rng = np.random.default_rng(seed)
    mask = np.zeros((360, 640), np.uint8)
    for _ in range(rng.integers(1, 5)):
        x, y = rng.integers(-40, 640), rng.integers(-40, 360)
        w, h = rng.integers(10, 160), rng.integers(10, 100)
        mask[max(y, 0):max(y + h, 0), max(x, 0):max(x + w, 0)] = 255
        mask[max(y, 0):max(y + h, 0), max(x + w // 2, 0):max(x + w // 2 + 3, 0)] = 0  # a gap the closing bridges
    mask[rng.random(mask.shape) < 0.15] ^= 255  # holes inside, speckle outside
    return mask


@pytest.mark.parametrize("seed", range(12))
def test_clean_mask_is_the_whole_frames(seed: int) -> None:
    """Exact equality, pixel for pixel."""
    mask = _blobby_mask(seed)
    np.testing.assert_array_equal(clean_mask(mask, PARAMS), _whole_frame_clean_mask(mask))


@pytest.mark.parametrize("seed", range(12))
def test_blob_boxes_are_the_whole_frames(seed: int) -> None:
    """The same boxes in the same order."""
    cleaned = _whole_frame_clean_mask(_blobby_mask(seed))
    assert blob_boxes(cleaned, 200) == _whole_frame_blob_boxes(cleaned, 200)


def test_an_empty_mask_has_no_blobs() -> None:
    empty = np.zeros((360, 640), np.uint8)
    assert occupied_box(empty) is None
    assert blob_boxes(empty, 1) == []
    assert not clean_mask(empty, PARAMS).any()


def test_the_occupied_box_grows_and_stays_in_the_frame() -> None:
    mask = np.zeros((100, 200), np.uint8)
    mask[2:10, 150:198] = 1
    assert occupied_box(mask) == Box(150, 2, 198, 10)
    assert occupied_box(mask, 5) == Box(145, 0, 200, 15)


def test_a_blob_with_no_change_against_the_full_background_is_a_ghost() -> None:
    """A car in front of a learnt road is a vehicle box; the same box is dropped once the full-resolution
    background shows the car too (the background model flags it, the frame does not differ there): a ghost."""
    params = RoiParams.from_config(history_frames=20)
    extractor = VehicleRoiExtractor(params)
    rng = np.random.default_rng(0)
    road = np.clip(120 + 6 * rng.standard_normal((240, 320, 3)), 0, 255).astype(np.uint8)
    for _ in range(params.history_frames):
        assert extractor.apply(road) == []
    car = road.copy()
    car[100:160, 120:220] = (40, 40, 200)
    (box,) = extractor.apply(car)
    assert box.intersection(Box(120, 100, 220, 160)) == Box(120, 100, 220, 160)
    assert extractor.changed_fraction(box) > 0.5
    extractor.background[100:160, 120:220] = (40, 40, 200)
    assert extractor.changed_fraction(box) == 0.0
    assert extractor.apply(car) == []


def test_the_ghost_share_is_checked() -> None:
    with pytest.raises(ConfigError, match=r"min_changed_fraction: must be in \[0, 1\], got 1.5"):
        RoiParams.from_config(min_changed_fraction=1.5)
