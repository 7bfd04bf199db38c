"""Track voting: each kept crop is classified once, the vote is the mean over the kept crops, and the
buffer thins itself to at most `capacity` crops spread over the track's life."""

from __future__ import annotations

import numpy as np

from vehloc.data.boxes import Box
from vehloc.geometry.pipeline.votes import TrackVotes


class CountingClassifier:
    """Stands in for the ONNX classifier: a crop's probabilities come from its mean brightness."""

    def __init__(self) -> None:
        self.crops_seen = 0

    def probabilities(self, images: list[np.ndarray], boxes: list[Box]) -> np.ndarray:
        self.crops_seen += len(images)
        levels = np.array([image.mean() / 255.0 for image in images])
        return np.stack([levels, 1.0 - levels], axis=1)


def _frame(level: int) -> np.ndarray:
    return np.full((60, 80, 3), level, dtype=np.uint8)


def test_each_crop_is_classified_once_and_the_vote_is_their_mean() -> None:
    votes, classifier = TrackVotes(capacity=4), CountingClassifier()
    box = Box(20, 20, 40, 40)
    levels = [0, 51, 102, 153, 204, 255, 0, 51, 102]
    for index, level in enumerate(levels):
        votes.add(_frame(level), box)
        vote = votes.vote(classifier)
        kept = [crop.mean() / 255.0 for crop, _ in votes.crops]
        np.testing.assert_allclose(vote, [np.mean(kept), 1.0 - np.mean(kept)], atol=1e-12)
        assert len(votes.crops) <= 4
    # Kept: frames 0-3; at frame 4 thinned to 0, 2, 4 (stride 2); frame 6 added; at frame 8 thinned to 0, 4, 8
    # (stride 4). Crops classified: frames 0-4, 6 and 8, once each.
    assert classifier.crops_seen == 7
    assert [crop.mean() for crop, _ in votes.crops] == [levels[0], levels[4], levels[8]]
