"""Vehicle ROI from a fixed camera: GMM background subtraction (MOG2), shadow removal, blobs, silhouettes.

MOG2 models every pixel as a mixture of Gaussians (3 here, as in the paper) learnt over a
150-frame history, then adapts more slowly (so that a car that stops is not absorbed into the
background within a second, while light changes still are over some seconds); it labels pixels
that match a background Gaussian but are darker by a bounded ratio as shadow, and those are dropped. Morphology closes the blob, connected components give
vehicle boxes (the tracker that follows them is the pipeline's: `vehloc.geometry.pipeline.tracker`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_interval, check_range, params_from_config
from vehloc.data.boxes import Box
from vehloc.geometry.chroma import chromaticity_shift
from vehloc.geometry.edge_coverage import edge_coverage

MOG2_SHADOW_VALUE = 127
MOG2_FOREGROUND_VALUE = 255


MAX_MIXTURES = 16
"""The most Gaussians per pixel the background model is given (MOG2's practical limit)."""
MAX_KERNEL_PX = 101
"""The largest window or kernel a setting may ask for (beyond, a single morphology step takes seconds a frame)."""


@dataclass(frozen=True)
class RoiParams:
    """Background model and blob filtering (kernel sizes in pixels of the frames as shrunk by `scale`)."""

    scale: float
    history_frames: int
    learning_rate_after_history: float
    mixtures: int
    var_threshold: float
    detect_shadows: bool
    shadow_threshold: float
    shadow_texture_window_px: int
    shadow_min_correlation: float
    shadow_min_texture: float
    open_kernel_px: int
    close_kernel_px: int
    min_area_fraction: float
    background_every_frames: int
    silhouette_threshold: float
    silhouette_shadow_ratio: tuple[float, float]
    silhouette_shadow_window_px: int
    silhouette_shadow_min_correlation: float
    silhouette_covered_max_correlation: float
    silhouette_covered_erode_px: int
    silhouette_doubt_max_chroma: float
    silhouette_doubt_bleed_px: int
    silhouette_doubt_bleed_min_change: float
    silhouette_close_px: int
    silhouette_doubt_weight: float
    silhouette_shade_weight: float
    silhouette_smooth_ratio: float
    silhouette_min_solid_px: int
    silhouette_min_part_fraction: float
    silhouette_edge_band_px: int
    silhouette_edge_min_contrast: float
    min_changed_fraction: float

    def __post_init__(self) -> None:
        check_range("scale", self.scale, 0.0, 1.0, low_open=True)  # above 1 the frames would be enlarged
        check_range("history_frames", self.history_frames, 1)
        check_range("learning_rate_after_history", self.learning_rate_after_history, 0.0, 1.0)
        check_range("mixtures", self.mixtures, 1, MAX_MIXTURES)
        check_range("var_threshold", self.var_threshold, 0.0, low_open=True)
        check_range("shadow_threshold", self.shadow_threshold, 0.0, 1.0)
        for name in ("shadow_texture_window_px", "open_kernel_px", "close_kernel_px", "background_every_frames",
                     "silhouette_shadow_window_px", "silhouette_close_px"):
            check_range(name, getattr(self, name), 1, MAX_KERNEL_PX if name.endswith("_px") else None)
        check_range("silhouette_min_solid_px", self.silhouette_min_solid_px, 1)  # a patch's pixel count
        for name in ("shadow_min_correlation", "silhouette_shadow_min_correlation", "silhouette_covered_max_correlation"):
            check_range(name, getattr(self, name), -1.0, 1.0)
        check_range("shadow_min_texture", self.shadow_min_texture, 0.0)
        check_range("min_area_fraction", self.min_area_fraction, 0.0, 1.0, high_open=True)
        check_range("silhouette_threshold", self.silhouette_threshold, 0.0, 255.0)
        check_interval("silhouette_shadow_ratio", self.silhouette_shadow_ratio, 0.0, 1.0)
        check_range("silhouette_covered_erode_px", self.silhouette_covered_erode_px, 0, MAX_KERNEL_PX)
        check_range("silhouette_doubt_max_chroma", self.silhouette_doubt_max_chroma, 0.0, 1.0)
        check_range("silhouette_doubt_bleed_px", self.silhouette_doubt_bleed_px, 0, MAX_KERNEL_PX)
        check_range("silhouette_doubt_bleed_min_change", self.silhouette_doubt_bleed_min_change, 0.0, 255.0)
        check_range("silhouette_doubt_weight", self.silhouette_doubt_weight, 0.0, 1.0)
        check_range("silhouette_shade_weight", self.silhouette_shade_weight, 0.0, 1.0)
        check_range("silhouette_smooth_ratio", self.silhouette_smooth_ratio, 0.0)
        check_range("min_changed_fraction", self.min_changed_fraction, 0.0, 1.0)
        check_range("silhouette_min_part_fraction", self.silhouette_min_part_fraction, 0.0, 1.0)
        check_range("silhouette_edge_band_px", self.silhouette_edge_band_px, 0, MAX_KERNEL_PX)
        check_range("silhouette_edge_min_contrast", self.silhouette_edge_min_contrast, 0.0, 255.0 * 3 ** 0.5)

    @classmethod
    def from_config(cls, **overrides: object) -> RoiParams:
        """The settings of `conf/localize/roi/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/roi/default.yaml", overrides)


def local_correlation(image: np.ndarray, reference: np.ndarray, window_px: int) -> tuple[np.ndarray, np.ndarray]:
    """Normalised cross-correlation of two grey images over a square window around every pixel,
    and the reference's local standard deviation (its texture)."""
    a, b = image.astype(np.float32), reference.astype(np.float32)
    size = (window_px, window_px)
    mean_a, mean_b = cv2.blur(a, size), cv2.blur(b, size)
    cov = cv2.blur(a * b, size) - mean_a * mean_b
    var_a = np.maximum(cv2.blur(a * a, size) - mean_a**2, 0)
    var_b = np.maximum(cv2.blur(b * b, size) - mean_b**2, 0)
    return cov / np.sqrt(var_a * var_b + 1e-3), np.sqrt(var_b)


def local_std(image: np.ndarray, window_px: int) -> np.ndarray:
    """A grey image's standard deviation over a square window around every pixel."""
    a = image.astype(np.float32)
    size = (window_px, window_px)
    return np.sqrt(np.maximum(cv2.blur(a * a, size) - cv2.blur(a, size) ** 2, 0))


def remove_shadows(
    mog2_mask: np.ndarray, frame_bgr: np.ndarray, background_bgr: np.ndarray | None, params: RoiParams
) -> np.ndarray:
    """Foreground without cast shadows.

    MOG2 flags as shadow every pixel darker than the background by a bounded ratio with little
    change of colour. On grey cars over grey roads that flags car body too, so where the background
    has texture a flagged pixel is taken as shadow only if that texture shows through (high local
    correlation with the background); elsewhere it stays foreground. Where the background has no
    texture to check, MOG2's label stands. The texture is compared only around the flagged pixels (the
    background image may be None when none is flagged)."""
    foreground = mog2_mask == MOG2_FOREGROUND_VALUE
    candidates = mog2_mask == MOG2_SHADOW_VALUE
    if candidates.any():
        x, y, w, h = cv2.boundingRect(candidates.astype(np.uint8))
        reach = params.shadow_texture_window_px
        around = Box(max(x - reach, 0), max(y - reach, 0), min(x + w + reach, mog2_mask.shape[1]),
                     min(y + h + reach, mog2_mask.shape[0]))
        grey = cv2.cvtColor(around.crop(frame_bgr), cv2.COLOR_BGR2GRAY)
        background_grey = cv2.cvtColor(around.crop(background_bgr), cv2.COLOR_BGR2GRAY)
        correlation, texture = local_correlation(grey, background_grey, params.shadow_texture_window_px)
        checkable = texture >= params.shadow_min_texture
        window = (slice(around.y0, around.y1), slice(around.x0, around.x1))
        foreground[window] |= candidates[window] & checkable & (correlation < params.shadow_min_correlation)
    return foreground.astype(np.uint8) * 255


def occupied_box(mask: np.ndarray, margin_px: int = 0) -> Box | None:
    """The box of a mask's non-zero pixels grown by `margin_px` on each side and clipped to the mask (None
    when the mask is empty): where the mask's operations have anything to do."""
    tight = Box.tight(mask)
    return None if tight is None else tight.grown(margin_px, mask.shape[1], mask.shape[0])


def clean_mask(mask: np.ndarray, params: RoiParams) -> np.ndarray:
    """Open away speckle, close gaps, and fill holes inside each blob. The closing and filling run only around
    what the opening left (far enough around for the result to be the whole frame's)."""
    opened = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((params.open_kernel_px,) * 2, np.uint8))
    filled = np.zeros_like(opened)
    around = occupied_box(opened, params.close_kernel_px)
    if around is None:
        return filled
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (params.close_kernel_px,) * 2)
    closed = cv2.morphologyEx(around.crop(opened), cv2.MORPH_CLOSE, kernel)
    contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(around.crop(filled), contours, -1, 255, cv2.FILLED)
    return filled


@dataclass(frozen=True, eq=False)
class Silhouette:
    """A vehicle's pixels in an ROI (bool mask), how much each weighs in the fit (1, or `silhouette_doubt_weight`
    where the pixel is doubtful; `silhouette_shade_weight` where such pixels are not solid and reach the outline),
    which are doubtful (only darker than the road, of its chromaticity: maybe shadow the texture test could not tell)
    and which are solid: sure, or darker but smooth where the road has texture (a body face, not a shadow on the
    road); and every pixel's light ratio (the frame's sum of channels over the background's), for a model of the
    shadow (`vehloc.geometry.road_shadow`); and along the outline, inside and out, the share of each pixel the vehicle
    covers where its colour tells (`edge_coverage`; NaN elsewhere, None when none was read)."""

    mask: np.ndarray
    weights: np.ndarray
    doubtful: np.ndarray
    solid: np.ndarray
    light_ratio: np.ndarray
    margin_px: int
    edge_share: np.ndarray | None = None

    def weights_at_edges(self) -> np.ndarray:
        """The fit's weights with the outline's pixels weighing the share of them the vehicle covers, where read."""
        if self.edge_share is None:
            return self.weights
        return np.where(np.isnan(self.edge_share), self.weights, self.edge_share)

    def trimmed(self) -> np.ndarray:
        """The mask without the pixels below the lowest solid one of each column (within `margin_px`, the
        texture window's reach): a shadow under the vehicle, which would otherwise pass for its bottom edge."""
        rows = np.arange(self.mask.shape[0])[:, None]
        solid = self.solid & self.mask
        lowest = np.where(solid.any(axis=0), self.mask.shape[0] - 1 - np.argmax(solid[::-1], axis=0), -1)
        return self.mask & (rows <= lowest[None, :] + self.margin_px)


def vehicle_silhouette(roi_bgr: np.ndarray, background_bgr: np.ndarray, params: RoiParams,
                       body: Box | None = None) -> Silhouette:
    """The vehicle's pixels in an ROI at full resolution, against the full-resolution background.

    A pixel is the vehicle's where its colour changed by more than `silhouette_threshold` (any channel) and it is
    no cast shadow (uniformly darker by a ratio within `silhouette_shadow_ratio` with the road's texture showing
    through: correlated with the background's over the window), or where the road has texture that no longer
    shows (correlation below `silhouette_covered_max_correlation`: a body face of the road's colour; shrunk by
    `silhouette_covered_erode_px`, as the window's reach would grow it onto the road). Closed, holes filled, the
    largest blob kept, and with it, where the vehicle's box in the ROI (`body`, the tracked box) is given, every
    blob of at least `silhouette_min_part_fraction` of its area whose centre lies in that box: a body face of the
    road's colour breaks a vehicle into parts (a grey side over grey asphalt cuts the wheels off). A pixel darker
    than the road that keeps its chromaticity (within `silhouette_doubt_max_chroma`; within
    `silhouette_doubt_bleed_px` of a pixel whose colour changed by more than `silhouette_doubt_bleed_min_change`, the
    least shift there: a coloured vehicle's chroma bleeds into its shadow, `vehloc.geometry.chroma`) may be shadow
    the texture test could not tell: it weighs `silhouette_doubt_weight` in the fit (dark paint of a colour weighs 1),
    and `silhouette_shade_weight` where it is not solid and its patch reaches the silhouette's outline (the shadow
    beside the vehicle, more likely than a part of it). Darker pixels
    are solid where their texture is below `silhouette_smooth_ratio` of the road's there (darkened alike): a smooth
    body face, unless they form a speck of fewer than `silhouette_min_solid_px` pixels (a deep shadow's compressed
    texture can look smooth here and there). Within `silhouette_edge_band_px` of the outline (inside and out) the share
    of each pixel the vehicle covers is read where its colour tells (`edge_coverage`): the threshold's in or out
    moves the outline by up to half a pixel."""
    frame = roi_bgr.astype(np.float32)
    background = background_bgr.astype(np.float32)
    changed = np.abs(frame - background).max(axis=2) > params.silhouette_threshold
    frame_sum, background_sum = frame.sum(axis=2) + 1.0, background.sum(axis=2) + 1.0
    ratio = frame_sum / background_sum
    low, high = params.silhouette_shadow_ratio
    darker = (ratio >= low) & (ratio <= high)
    grey = cv2.cvtColor(roi_bgr, cv2.COLOR_BGR2GRAY)
    correlation, texture = local_correlation(grey, cv2.cvtColor(background_bgr, cv2.COLOR_BGR2GRAY),
                                             params.silhouette_shadow_window_px)
    textured = texture >= params.shadow_min_texture
    shadow = darker & textured & (correlation >= params.silhouette_shadow_min_correlation)
    reach = params.silhouette_covered_erode_px
    covered = cv2.erode((textured & (correlation < params.silhouette_covered_max_correlation)).astype(np.uint8),
                        np.ones((2 * reach + 1,) * 2, np.uint8)) > 0
    mask = (((changed & ~shadow) | covered) * 255).astype(np.uint8)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (params.silhouette_close_px,) * 2)
    mask = cv2.morphologyEx(cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8)), cv2.MORPH_CLOSE, kernel)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros_like(mask)
    if contours:
        cv2.drawContours(filled, vehicle_parts(contours, body, params.silhouette_min_part_fraction), -1, 255,
                         cv2.FILLED)
    vehicle = filled > 0
    darker_than_road = ratio <= high
    chroma_shift = chromaticity_shift(roi_bgr, background_bgr, params.silhouette_doubt_bleed_px,
                                      params.silhouette_doubt_bleed_min_change)
    doubtful = darker_than_road & (chroma_shift < params.silhouette_doubt_max_chroma)
    window = params.silhouette_shadow_window_px
    smooth = local_std(grey, window) < params.silhouette_smooth_ratio * ratio * texture
    solid = without_specks(vehicle & (~darker_than_road | smooth), params.silhouette_min_solid_px)
    doubt_weight = params.silhouette_doubt_weight
    if params.silhouette_shade_weight != doubt_weight:  # the outline's patches only where they weigh otherwise
        shade = at_outline(vehicle & doubtful & ~solid, vehicle)
        doubt_weight = np.where(shade, params.silhouette_shade_weight, doubt_weight)
    edge_share = None
    if params.silhouette_edge_band_px:
        share, known = edge_coverage(roi_bgr, background_bgr, vehicle, doubtful, params.silhouette_edge_band_px,
                                     params.silhouette_edge_min_contrast)
        edge_share = np.where(known, share, np.nan).astype(np.float32)
    return Silhouette(vehicle, np.where(vehicle, np.where(doubtful, doubt_weight, 1.0), 0.0), vehicle & doubtful,
                      solid, ratio, window // 2, edge_share)


def vehicle_parts(contours: Sequence[np.ndarray], body: Box | None, min_part_fraction: float) -> list[np.ndarray]:
    """The largest blob's outline and, with `body` given, those of the blobs of at least `min_part_fraction` of its
    area whose centre (of their outline's box) lies inside `body`."""
    areas = [cv2.contourArea(contour) for contour in contours]
    largest = int(np.argmax(areas))
    parts = [contours[largest]]
    if body is None:
        return parts
    for index, contour in enumerate(contours):
        x, y, w, h = cv2.boundingRect(contour)
        if (index != largest and areas[index] >= min_part_fraction * areas[largest]
                and body.x0 <= x + w / 2 < body.x1 and body.y0 <= y + h / 2 < body.y1):
            parts.append(contour)
    return parts


def at_outline(part: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The 8-connected components of `part` (inside the bool `mask`) that reach the mask's outline: a pixel of theirs
    has a 4-neighbour outside the mask (or lies on the image's border)."""
    outside = np.pad(~mask, 1, constant_values=True)
    rim = mask & (outside[:-2, 1:-1] | outside[2:, 1:-1] | outside[1:-1, :-2] | outside[1:-1, 2:])
    count, labels = cv2.connectedComponents(part.astype(np.uint8), connectivity=8)
    reaching = np.zeros(count, bool)
    reaching[np.unique(labels[part & rim])] = True
    reaching[0] = False
    return reaching[labels]


def without_specks(mask: np.ndarray, min_area_px: int) -> np.ndarray:
    """A bool mask without its 8-connected components of fewer than `min_area_px` pixels."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area_px
    keep[0] = False
    return keep[labels]


def scaled_box(box: Box, factor: float, width_px: int, height_px: int) -> Box:
    """The pixels of a box on an image scaled by `factor`: the smallest box holding them, clipped."""
    return Box(int(np.floor(box.x0 * factor)), int(np.floor(box.y0 * factor)),
               int(np.ceil(box.x1 * factor)), int(np.ceil(box.y1 * factor))).clipped(width_px, height_px)


def blob_boxes(mask: np.ndarray, min_area_px: int) -> list[Box]:
    """Boxes of the connected components at least `min_area_px` large, largest first."""
    around = occupied_box(mask)
    if around is None:
        return []
    count, _, stats, _ = cv2.connectedComponentsWithStats(around.crop(mask), connectivity=8)
    boxes = [
        (area, Box(int(x) + around.x0, int(y) + around.y0, int(x + w) + around.x0, int(y + h) + around.y0))
        for x, y, w, h, area in stats[1:count]
        if area >= min_area_px
    ]
    return [box for _, box in sorted(boxes, key=lambda item: -item[0])]


class VehicleRoiExtractor:
    """Feeds frames to MOG2 and returns the vehicle boxes of each frame once the history is learnt."""

    def __init__(self, params: RoiParams | None = None) -> None:
        self.params = params or RoiParams.from_config()
        self.subtractor = cv2.createBackgroundSubtractorMOG2(
            history=self.params.history_frames,
            varThreshold=self.params.var_threshold,
            detectShadows=self.params.detect_shadows,
        )
        self.subtractor.setNMixtures(self.params.mixtures)
        self.subtractor.setShadowThreshold(self.params.shadow_threshold)
        self.frames_seen = 0
        self.last_mask: np.ndarray | None = None
        self.last_frame: np.ndarray | None = None
        self.background: np.ndarray | None = None
        self.small_background: np.ndarray | None = None
        self.background_samples = 0

    @property
    def ready(self) -> bool:
        """Whether the background has been learnt over the full history."""
        return self.frames_seen >= self.params.history_frames

    def apply(self, frame_bgr: np.ndarray) -> list[Box]:
        """Update the model with a frame; its vehicle boxes in frame pixels (none while the history is being
        learnt)."""
        scale = self.params.scale
        small = frame_bgr if scale == 1.0 else cv2.resize(frame_bgr, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        rate = -1.0 if not self.ready else self.params.learning_rate_after_history
        raw = self.subtractor.apply(small, learningRate=rate)
        self.frames_seen += 1
        self.last_frame = frame_bgr
        sampled = (self.frames_seen - 1) % self.params.background_every_frames == 0
        if self.ready:  # while the history is learnt there are no boxes, so no mask: only the backgrounds learn
            if sampled or self.small_background is None:
                self.small_background = self.subtractor.getBackgroundImage()
            self.last_mask = clean_mask(remove_shadows(raw, small, self.small_background, self.params), self.params)
        if sampled:
            self._update_background(frame_bgr)
        if not self.ready:
            return []
        height_px, width_px = small.shape[:2]
        boxes = blob_boxes(self.last_mask, int(self.params.min_area_fraction * width_px * height_px))
        frame_height_px, frame_width_px = frame_bgr.shape[:2]
        boxes = [scaled_box(box, 1.0 / scale, frame_width_px, frame_height_px) for box in boxes]
        return [box for box in boxes if self.changed_fraction(box) >= self.params.min_changed_fraction]

    def changed_fraction(self, box: Box) -> float:
        """The share of the last frame's pixels in `box` whose colour differs from the full-resolution
        background's by more than `silhouette_threshold` (in some channel): about none for a ghost of the
        background model, where it flags road it has not relearnt."""
        blue, green, red = cv2.split(cv2.absdiff(box.crop(self.last_frame), box.crop(self.background).astype(np.uint8)))
        largest = cv2.max(cv2.max(blue, green), red)
        return np.count_nonzero(largest > self.params.silhouette_threshold) / largest.size

    def _update_background(self, frame_bgr: np.ndarray) -> None:
        """The full-resolution background: the running mean of the sampled frames while the history is learnt,
        then a slow update where the background model sees no vehicle."""
        self.background_samples += 1
        if self.background is None:
            self.background = frame_bgr.astype(np.float32)
            return
        if not self.ready:
            cv2.accumulateWeighted(frame_bgr, self.background, 1.0 / self.background_samples)
            return
        still = cv2.resize(self.last_mask, frame_bgr.shape[1::-1], interpolation=cv2.INTER_NEAREST) == 0
        rate = min(1.0, self.params.learning_rate_after_history * self.params.background_every_frames)
        cv2.accumulateWeighted(frame_bgr, self.background, rate, still.astype(np.uint8))

    def foreground(self, roi: Box, body: Box | None = None) -> Silhouette:
        """The last frame's vehicle pixels inside `roi` (frame pixels), at full resolution, `body` the vehicle's box
        there (frame pixels; see `vehicle_silhouette`)."""
        if self.last_frame is None or self.background is None:
            raise RuntimeError("no frame has been applied yet")
        background = roi.crop(self.background).astype(np.uint8)
        inside = None if body is None else body.shifted(-roi.x0, -roi.y0)
        return vehicle_silhouette(roi.crop(self.last_frame), background, self.params, inside)
