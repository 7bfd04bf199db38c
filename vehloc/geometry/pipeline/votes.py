"""Classification once per track: the vehicle's ROI crops gathered over its frames, each classified once,
their probabilities averaged (track voting, as BoxCars does)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehloc.data.boxes import Box
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.preprocess import MIN_SIDE_PX

CROP_MARGIN = 0.25
"""Each kept crop is the vehicle's box grown by this fraction a side, enough for the classifier's own ROI."""


@dataclass
class TrackVotes:
    """Up to `capacity` frames' crops of one track, spread over its whole life: every `stride`-th frame is
    kept, and when the buffer is full every other crop is dropped and the stride doubles."""

    capacity: int
    crops: list[tuple[np.ndarray, Box]] = field(default_factory=list)
    crop_probabilities: list[np.ndarray] = field(default_factory=list)
    stride: int = 1
    seen: int = 0

    def add(self, frame_bgr: np.ndarray, box: Box) -> None:
        """Offer this frame's view of the vehicle in `box`; a box too small to classify (under the classifier's
        `MIN_SIDE_PX` a side: its ROI is the box, maybe enlarged) is not kept."""
        if min(box.width_px, box.height_px) < MIN_SIDE_PX:
            return
        if self.seen % self.stride == 0:
            around = box.enlarged(CROP_MARGIN, frame_bgr.shape[1], frame_bgr.shape[0])
            inside = Box(box.x0 - around.x0, box.y0 - around.y0, box.x1 - around.x0, box.y1 - around.y0)
            self.crops.append((around.crop(frame_bgr).copy(), inside))
            if len(self.crops) > self.capacity:
                self.crops = self.crops[::2]
                self.crop_probabilities = self.crop_probabilities[::2]
                self.stride *= 2
        self.seen += 1

    @property
    def empty(self) -> bool:
        """No crop was big enough to classify: there is nothing to vote on."""
        return not self.crops

    def vote(self, classifier: VehicleClassifier) -> np.ndarray:
        """The class probabilities averaged over the kept crops (each crop classified once, when first voted);
        ValueError when there is none (`empty`)."""
        if self.empty:
            raise ValueError("no crop to vote on")
        new = self.crops[len(self.crop_probabilities):]
        if new:
            images, boxes = zip(*new)
            self.crop_probabilities.extend(classifier.probabilities(list(images), list(boxes)))
        return np.mean(self.crop_probabilities, axis=0)
