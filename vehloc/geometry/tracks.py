"""Classification once per track: the vehicle's ROI crops gathered over its frames, classified together,
their probabilities averaged (track voting, as BoxCars does)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehloc.data.boxes import Box
from vehloc.infer.classifier import VehicleClassifier

CROP_MARGIN = 0.25
"""Each kept crop is the vehicle's box grown by this fraction a side, enough for the classifier's own ROI."""


@dataclass
class TrackVotes:
    """Up to `capacity` frames' crops of one track, spread over its whole life: every `stride`-th frame is
    kept, and when the buffer is full every other crop is dropped and the stride doubles."""

    capacity: int
    crops: list[tuple[np.ndarray, Box]] = field(default_factory=list)
    stride: int = 1
    seen: int = 0
    probabilities: np.ndarray | None = None

    def add(self, frame_bgr: np.ndarray, box: Box) -> None:
        """Offer this frame's view of the vehicle in `box`."""
        if self.seen % self.stride == 0:
            around = box.enlarged(CROP_MARGIN, frame_bgr.shape[1], frame_bgr.shape[0])
            inside = Box(box.x0 - around.x0, box.y0 - around.y0, box.x1 - around.x0, box.y1 - around.y0)
            self.crops.append((around.crop(frame_bgr).copy(), inside))
            self.probabilities = None
            if len(self.crops) > self.capacity:
                self.crops = self.crops[::2]
                self.stride *= 2
        self.seen += 1

    def vote(self, classifier: VehicleClassifier) -> np.ndarray:
        """The class probabilities averaged over the kept crops (computed once until new crops come)."""
        if self.probabilities is None:
            images, boxes = zip(*self.crops)
            self.probabilities = classifier.probabilities(list(images), list(boxes)).mean(axis=0)
        return self.probabilities
