"""The one box convention inside vehloc: 0-based, half-open pixel bounds, ``x0 <= x < x1`` and
``y0 <= y < y1``, so that ``image[box.y0:box.y1, box.x0:box.x1]`` is the box and its width is
``x1 - x0``. Files use other conventions, converted here where they are read or written: CompCars labels
(1-based, inclusive) and the scene ground truth (0-based, inclusive)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class Box:
    """Axis-aligned box in pixels, 0-based and half-open."""

    x0: int
    y0: int
    x1: int
    y1: int

    @classmethod
    def from_compcars_label(cls, x1: int, y1: int, x2: int, y2: int) -> Box:
        """A CompCars label box: 1-based, inclusive of its last column and row."""
        return cls(x1 - 1, y1 - 1, x2, y2)

    def to_compcars_label(self) -> tuple[int, int, int, int]:
        """(x1, y1, x2, y2), 1-based and inclusive, as CompCars label files write it."""
        return self.x0 + 1, self.y0 + 1, self.x1, self.y1

    @classmethod
    def from_inclusive(cls, x1: int, y1: int, x2: int, y2: int) -> Box:
        """A 0-based box inclusive of its last column and row (the scene ground truth's convention)."""
        return cls(x1, y1, x2 + 1, y2 + 1)

    def to_inclusive(self) -> tuple[int, int, int, int]:
        """(x1, y1, x2, y2), 0-based and inclusive, as the scene ground truth writes it."""
        return self.x0, self.y0, self.x1 - 1, self.y1 - 1

    @classmethod
    def tight(cls, mask: np.ndarray) -> Box | None:
        """The smallest box holding every true (non-zero) pixel of a mask; None when there is none."""
        pixels = mask if mask.dtype == np.uint8 else np.ascontiguousarray(mask, dtype=bool).view(np.uint8)
        x, y, w, h = cv2.boundingRect(pixels)
        return cls(x, y, x + w, y + h) if w else None

    @property
    def width_px(self) -> int:
        return self.x1 - self.x0

    @property
    def height_px(self) -> int:
        return self.y1 - self.y0

    @property
    def is_empty(self) -> bool:
        return self.width_px <= 0 or self.height_px <= 0

    @property
    def area_px(self) -> int:
        return 0 if self.is_empty else self.width_px * self.height_px

    @property
    def centre_px(self) -> np.ndarray:
        """The centre in continuous pixel coordinates (pixel centres at integers)."""
        return np.array([(self.x0 + self.x1 - 1) / 2, (self.y0 + self.y1 - 1) / 2])

    def intersection(self, other: Box) -> Box:
        """The overlap of two boxes (empty when they do not overlap)."""
        return Box(max(self.x0, other.x0), max(self.y0, other.y0), min(self.x1, other.x1), min(self.y1, other.y1))

    def shifted(self, dx_px: int, dy_px: int) -> Box:
        """The box moved by (dx_px, dy_px): from a crop's pixels to the image's, or back with the negatives."""
        return Box(self.x0 + dx_px, self.y0 + dy_px, self.x1 + dx_px, self.y1 + dy_px)

    def union(self, other: Box) -> Box:
        """The smallest box holding both."""
        return Box(min(self.x0, other.x0), min(self.y0, other.y0), max(self.x1, other.x1), max(self.y1, other.y1))

    def iou(self, other: Box) -> float:
        inter = self.intersection(other).area_px
        union = self.area_px + other.area_px - inter
        return inter / union if union else 0.0

    def clipped(self, width_px: int, height_px: int) -> Box:
        """The part of the box inside a `width_px` x `height_px` image."""
        return self.intersection(Box(0, 0, width_px, height_px))

    def enlarged(self, fraction: float, width_px: int, height_px: int) -> Box:
        """The box grown by `fraction` of its width and height on each side, clipped to the image."""
        pad_x, pad_y = round(self.width_px * fraction), round(self.height_px * fraction)
        return Box(self.x0 - pad_x, self.y0 - pad_y, self.x1 + pad_x, self.y1 + pad_y).clipped(width_px, height_px)

    def grown(self, margin_px: int, width_px: int, height_px: int) -> Box:
        """The box grown by `margin_px` on each side, clipped to the image."""
        return Box(self.x0 - margin_px, self.y0 - margin_px, self.x1 + margin_px, self.y1 + margin_px).clipped(
            width_px, height_px)

    def touches_border(self, width_px: int, height_px: int, margin_px: int = 0) -> bool:
        """Whether the box reaches within `margin_px` of the image's edge (the object may be cut by it)."""
        return (self.x0 <= margin_px or self.y0 <= margin_px or self.x1 >= width_px - margin_px
                or self.y1 >= height_px - margin_px)

    def crop(self, image: np.ndarray) -> np.ndarray:
        """The pixels of `image` under the box (a view); ValueError when the box and the image do not overlap."""
        height_px, width_px = image.shape[:2]
        inside = self.clipped(width_px, height_px)
        if inside.is_empty:
            raise ValueError(f"box {self.as_tuple()} lies outside the {width_px}x{height_px} image")
        return image[inside.y0:inside.y1, inside.x0:inside.x1]

    def as_tuple(self) -> tuple[int, int, int, int]:
        return self.x0, self.y0, self.x1, self.y1
