"""The one preprocessing's aspect handling: a ROI padded to a square keeps its shape, in evaluation (NumPy) and
training (torchvision) alike; files written before the option read as squashing."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.preprocess import PAD_GREY, Preprocessing, padded_square
from vehloc.train.transforms import TrainTransform


def _white_roi(height_px: int, width_px: int) -> np.ndarray:
    return np.full((height_px, width_px, 3), 255, np.uint8)


def test_padded_square_centres_the_roi_on_grey() -> None:
    roi = np.arange(20 * 60 * 3, dtype=np.uint32).reshape(20, 60, 3).astype(np.uint8)
    square = padded_square(roi)
    assert square.shape == (60, 60, 3)
    np.testing.assert_array_equal(square[20:40], roi)
    assert np.all(square[:20] == PAD_GREY) and np.all(square[40:] == PAD_GREY)
    tall = padded_square(_white_roi(61, 20))
    assert tall.shape == (61, 61, 3) and np.all(tall[:, :20] == PAD_GREY) and np.all(tall[:, 20:40] == 255)
    assert np.all(tall[:, 40:] == PAD_GREY)


@pytest.mark.parametrize("keep_aspect, white_rows", [(True, 16), (False, 48)])
def test_to_input_keeps_or_squashes_a_wide_roi(keep_aspect: bool, white_rows: int) -> None:
    """A white 40 x 120 px ROI at 48 px: a 16-row white band between grey bars when the aspect is kept (exact:
    the bars are 40 px of the 120 px square), all white when squashed."""
    preprocessing = Preprocessing(48, 48, 0.0, (0.0,) * 3, (1.0,) * 3, keep_aspect)
    rows = preprocessing.to_input(_white_roi(40, 120))[0, :, 24]
    assert np.sum(rows == 1.0) == white_rows
    if keep_aspect:
        assert np.allclose(rows[:16], PAD_GREY / 255.0) and np.allclose(rows[-16:], PAD_GREY / 255.0)


def test_training_pads_like_evaluation() -> None:
    """With no random crop, flip or jitter, training's input of a wide ROI has evaluation's grey bars (same rows,
    pixel values within 1/255 but for the two rows at each edge, which resampling blends)."""
    roi = _white_roi(40, 120)
    train = TrainTransform(48, keep_aspect=True, crop_scale=(1.0, 1.0), crop_ratio=(1.0, 1.0), hflip=False,
                           color_jitter=0.0)(roi).numpy()
    evaluation = Preprocessing(48, 48, 0.0, (0.0,) * 3, (1.0,) * 3, True).to_input(roi)
    inner = [*range(0, 15), *range(17, 31), *range(33, 48)]
    np.testing.assert_allclose(train[:, inner], evaluation[:, inner], atol=1.0 / 255)


def test_keep_aspect_round_trips_and_old_files_squash() -> None:
    kept = Preprocessing(64, 72, 0.1, (0.5,) * 3, (0.25,) * 3, True)
    assert Preprocessing.from_dict(kept.as_dict()) == kept
    old = {k: v for k, v in kept.as_dict().items() if k != "keep_aspect"}
    assert Preprocessing.from_dict(old).keep_aspect is False
    with pytest.raises(ValueError, match="keep_aspect must be true or false, got 'yes'"):
        Preprocessing.from_dict({**kept.as_dict(), "keep_aspect": "yes"})
