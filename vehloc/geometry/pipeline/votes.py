"""Classification once per track: the vehicle's ROI crops gathered over its frames, each classified once,
their probabilities averaged (track voting, as BoxCars does). The crops kept are spread over the track's life
(`spread`: a vehicle that stops is seen from every side it showed), or its largest views (`largest`: a vehicle
that passes through is classified where it is seen best, not where it is a few pixels far away)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehloc.data.boxes import Box
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.preprocess import MIN_SIDE_PX

CROP_MARGIN = 0.25
"""Each kept crop is the vehicle's box grown by this fraction a side, enough for the classifier's own ROI."""
VOTE_POLICIES = ("spread", "largest")


@dataclass
class TrackVotes:
    """Up to `capacity` frames' crops of one track. `spread`: over its whole life, every `stride`-th frame kept, and
    when the buffer is full every other crop dropped and the stride doubled. `largest`: the crops of its largest
    boxes, a larger one replacing the smallest kept."""

    capacity: int
    policy: str = "spread"
    crops: list[tuple[np.ndarray, Box]] = field(default_factory=list)
    crop_probabilities: list[np.ndarray | None] = field(default_factory=list)
    stride: int = 1
    seen: int = 0

    def __post_init__(self) -> None:
        if self.policy not in VOTE_POLICIES:
            raise ValueError(f"vote policy must be one of {', '.join(VOTE_POLICIES)}, got {self.policy!r}")

    def add(self, frame_bgr: np.ndarray, box: Box, cut: bool = False) -> None:
        """Offer this frame's view of the vehicle in `box`; a box too small to classify (under the classifier's
        `MIN_SIDE_PX` a side: its ROI is the box, maybe enlarged) is not kept, nor, by `largest`, a view the frame's
        edge `cut` (large, not the best)."""
        if min(box.width_px, box.height_px) < MIN_SIDE_PX or (cut and self.policy == "largest"):
            return
        if self.policy == "largest":
            if len(self.crops) < self.capacity:
                self._keep(frame_bgr, box)
            else:
                smallest = min(range(len(self.crops)), key=lambda i: self.crops[i][1].area_px)
                if box.area_px > self.crops[smallest][1].area_px:
                    del self.crops[smallest], self.crop_probabilities[smallest]
                    self._keep(frame_bgr, box)
        elif self.seen % self.stride == 0:
            self._keep(frame_bgr, box)
            if len(self.crops) > self.capacity:
                self.crops = self.crops[::2]
                self.crop_probabilities = self.crop_probabilities[::2]
                self.stride *= 2
        self.seen += 1

    def _keep(self, frame_bgr: np.ndarray, box: Box) -> None:
        around = box.enlarged(CROP_MARGIN, frame_bgr.shape[1], frame_bgr.shape[0])
        inside = Box(box.x0 - around.x0, box.y0 - around.y0, box.x1 - around.x0, box.y1 - around.y0)
        self.crops.append((around.crop(frame_bgr).copy(), inside))
        self.crop_probabilities.append(None)

    @property
    def empty(self) -> bool:
        """No crop was big enough to classify: there is nothing to vote on."""
        return not self.crops

    def vote(self, classifier: VehicleClassifier) -> np.ndarray:
        """The class probabilities averaged over the kept crops (each crop classified once, when first voted);
        ValueError when there is none (`empty`)."""
        if self.empty:
            raise ValueError("no crop to vote on")
        new = [i for i, probabilities in enumerate(self.crop_probabilities) if probabilities is None]
        if new:
            images, boxes = zip(*(self.crops[i] for i in new))
            for i, probabilities in zip(new, classifier.probabilities(list(images), list(boxes))):
                self.crop_probabilities[i] = probabilities
        return np.mean(self.crop_probabilities, axis=0)
