"""The full-resolution vehicle silhouette against a textured road: a body face darker than the road stays the
vehicle's (doubtful but solid); below it, a darker grainy band the shadow test cannot tell from the vehicle
(its grain does not correlate with the road's, as under a car where the light is mottled) is in the mask but
doubtful and not solid, and the trimmed mask ends at the face's bottom edge."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.config import ConfigError
from vehloc.data.boxes import Box
from vehloc.geometry.roi import RoiParams, vehicle_silhouette, without_specks

FACE_ROWS, FACE_COLUMNS = (20, 60), (30, 90)  # the body face, half-open rows and columns
SHADOW_ROWS = (60, 75)                        # the grainy dark band below it


def _road(shape: tuple[int, int], seed: int) -> np.ndarray:
    """A grey road with the grain of asphalt (level 120, standard deviation about 8)."""
    rng = np.random.default_rng(seed)
    grey = np.clip(120 + 8 * rng.standard_normal(shape), 0, 255)
    return np.repeat(grey[:, :, None], 3, axis=2).astype(np.uint8)


@pytest.fixture(scope="module")
def scene() -> tuple[np.ndarray, np.ndarray]:
    background = _road((100, 120), seed=1)
    frame = background.copy()
    frame[slice(*SHADOW_ROWS), slice(*FACE_COLUMNS)] = _road((SHADOW_ROWS[1] - SHADOW_ROWS[0],
                                                              FACE_COLUMNS[1] - FACE_COLUMNS[0]), seed=2) // 2
    frame[slice(*FACE_ROWS), slice(*FACE_COLUMNS)] = (70, 72, 75)  # a smooth dark-grey body face
    return frame, background


def test_the_face_is_solid_and_its_shadow_is_not(scene: tuple[np.ndarray, np.ndarray]) -> None:
    frame, background = scene
    silhouette = vehicle_silhouette(frame, background, RoiParams.from_config())
    face = (slice(FACE_ROWS[0] + 4, FACE_ROWS[1] - 4), slice(FACE_COLUMNS[0] + 4, FACE_COLUMNS[1] - 4))
    shadow = (slice(SHADOW_ROWS[0] + 4, SHADOW_ROWS[1] - 4), slice(FACE_COLUMNS[0] + 4, FACE_COLUMNS[1] - 4))
    assert silhouette.mask[face].all() and silhouette.solid[face].all()
    assert (silhouette.weights[face] < 1.0).all()  # darker than the road: doubtful for the fit
    assert silhouette.mask[shadow].all() and (silhouette.weights[shadow] < 1.0).all()
    assert not silhouette.solid[shadow].any()


def test_the_trimmed_mask_ends_at_the_face_bottom(scene: tuple[np.ndarray, np.ndarray]) -> None:
    """Each inner column's lowest trimmed pixel lies within the texture window's half (3 px) of the face's
    bottom row, whatever the shadow below it does to the untrimmed mask."""
    frame, background = scene
    silhouette = vehicle_silhouette(frame, background, RoiParams.from_config())
    trimmed = silhouette.trimmed()
    columns = range(FACE_COLUMNS[0] + 4, FACE_COLUMNS[1] - 4)
    lowest = np.array([np.flatnonzero(trimmed[:, c]).max() for c in columns])
    assert np.all(np.abs(lowest - (FACE_ROWS[1] - 1)) <= 3), lowest
    assert silhouette.mask[SHADOW_ROWS[1] - 2].any() and not trimmed[FACE_ROWS[1] + 4:].any()


def test_a_smooth_speck_in_the_shadow_does_not_extend_the_trimmed_mask(scene: tuple[np.ndarray, np.ndarray]) -> None:
    """A flat 7 x 6 px patch in the shadow band (a deep shadow's texture, flattened by compression, can look like
    this) passes the smoothness test at a few pixels; kept, that speck would carry the trimmed mask down to it."""
    frame, background = scene
    frame = frame.copy()
    frame[66:73, 50:56] = 60
    speck_kept = vehicle_silhouette(frame, background, RoiParams.from_config(silhouette_min_solid_px=1))
    assert speck_kept.solid[SHADOW_ROWS[0]:].any()
    silhouette = vehicle_silhouette(frame, background, RoiParams.from_config())
    assert not silhouette.solid[SHADOW_ROWS[0]:].any()
    assert not silhouette.trimmed()[FACE_ROWS[1] + 4:].any()


def test_without_specks_drops_only_the_small_components() -> None:
    mask = np.zeros((20, 20), dtype=bool)
    mask[2:6, 2:6] = True      # 16 px
    mask[10:12, 10:13] = True  # 6 px
    mask[15, 15] = mask[16, 16] = True  # 2 px, 8-connected
    kept = without_specks(mask, 6)
    assert kept[2:6, 2:6].all() and kept[10:12, 10:13].all()
    assert kept.sum() == 22


def test_the_speck_size_is_checked():
    with pytest.raises(ConfigError, match="silhouette_min_solid_px: must be >= 1, got 0"):
        RoiParams.from_config(silhouette_min_solid_px=0)


def test_a_face_of_the_roads_colour_covers_the_road_to_within_a_pixel():
    """A smooth face at the road's own mean level (no colour change to see) hides the road's grain: its inside,
    beyond the texture window's reach and the erosion (3 + 2 px) and one more pixel, is the vehicle's, and the
    mask reaches past the face's edges by at most a pixel; with the cue off, nothing of it is found."""
    background = _road((100, 120), seed=1)
    frame = background.copy()
    frame[slice(*FACE_ROWS), slice(*FACE_COLUMNS)] = 120
    mask = vehicle_silhouette(frame, background, RoiParams.from_config()).mask
    inner = (slice(FACE_ROWS[0] + 6, FACE_ROWS[1] - 6), slice(FACE_COLUMNS[0] + 6, FACE_COLUMNS[1] - 6))
    assert mask[inner].all()
    grown = np.zeros_like(mask)
    grown[FACE_ROWS[0] - 1:FACE_ROWS[1] + 1, FACE_COLUMNS[0] - 1:FACE_COLUMNS[1] + 1] = True
    assert not (mask & ~grown).any()
    assert not vehicle_silhouette(frame, background, RoiParams.from_config(silhouette_covered_max_correlation=-1.0)).mask.any()


def test_dark_paint_of_a_colour_weighs_fully_and_dark_grey_is_doubted(scene: tuple[np.ndarray, np.ndarray]) -> None:
    """Darker than the road, a dark red face shifts the chromaticity and is the vehicle's for the fit (weight 1);
    the dark-grey face keeps the road's and may be shadow (the doubt weight)."""
    frame, background = scene
    red = frame.copy()
    red[slice(*FACE_ROWS), slice(*FACE_COLUMNS)] = (40, 40, 110)  # BGR
    params = RoiParams.from_config()
    face = (slice(FACE_ROWS[0] + 4, FACE_ROWS[1] - 4), slice(FACE_COLUMNS[0] + 4, FACE_COLUMNS[1] - 4))
    assert (vehicle_silhouette(red, background, params).weights[face] == 1.0).all()
    assert (vehicle_silhouette(frame, background, params).weights[face] == params.silhouette_doubt_weight).all()


def test_a_vehicle_broken_by_a_band_of_the_roads_look_keeps_both_parts_inside_its_box():
    """A white body (rows 20-44) over a dark lower part with its wheels (rows 55-65), joined by a band that looks
    like the road (the road's own grain: neither changed nor covered) 10 px high: two blobs. Without the vehicle's
    box the larger alone is the silhouette and the lower part is lost; with it, the lower part (centred inside the
    box, a third of the body's area) is the vehicle's too. A blob of another vehicle beside the box is not."""
    background = _road((100, 140), seed=1)
    frame = background.copy()
    frame[20:45, 30:90] = 230
    frame[55:66, 34:86] = 40
    frame[75:85, 120:135] = 230  # another vehicle's part, outside the box
    params = RoiParams.from_config()
    alone = vehicle_silhouette(frame, background, params).mask
    assert alone[25:40, 35:85].all() and not alone[57:64, 38:82].any()
    parts = vehicle_silhouette(frame, background, params, Box(28, 18, 92, 68)).mask
    assert parts[25:40, 35:85].all() and parts[57:64, 38:82].all() and not parts[75:85, 120:135].any()
    off = vehicle_silhouette(frame, background, RoiParams.from_config(silhouette_min_part_fraction=1.0),
                             Box(28, 18, 92, 68)).mask
    assert not off[57:64, 38:82].any()


def test_a_grainy_dark_band_at_the_outline_weighs_as_shade_and_one_enclosed_by_the_body_does_not(
        scene: tuple[np.ndarray, np.ndarray]) -> None:
    """With `silhouette_shade_weight` below the doubt weight: the grainy band below the face reaches the
    silhouette's outline, likely the shadow next to the vehicle, and weighs the shade weight in the fit; the smooth
    face keeps the doubt weight. The same grain enclosed by a white body (a window with the light mottled on it) is
    the vehicle's inside: the doubt weight."""
    frame, background = scene
    params = RoiParams.from_config(silhouette_shade_weight=0.25)
    weights = vehicle_silhouette(frame, background, params).weights
    face = (slice(FACE_ROWS[0] + 4, FACE_ROWS[1] - 4), slice(FACE_COLUMNS[0] + 4, FACE_COLUMNS[1] - 4))
    band = (slice(SHADOW_ROWS[0] + 4, SHADOW_ROWS[1] - 4), slice(FACE_COLUMNS[0] + 4, FACE_COLUMNS[1] - 4))
    assert (weights[face] == params.silhouette_doubt_weight).all()
    assert np.mean(weights[band] == params.silhouette_shade_weight) > 0.9
    enclosed = background.copy()
    enclosed[10:90, 20:100] = 235
    enclosed[35:65, 40:80] = _road((30, 40), seed=2) // 2
    weights = vehicle_silhouette(enclosed, background, params).weights
    window = (slice(39, 61), slice(44, 76))
    assert not (weights[window] == params.silhouette_shade_weight).any()
    assert np.mean(weights[window] == params.silhouette_doubt_weight) > 0.9
