"""The one preprocessing of the classifier, from an image file and a vehicle box to the network's input:
the box enlarged on each side (the paper's 10 %), the ROI padded to a square with grey (`keep_aspect`, so a
side view keeps its length-to-height cue) or squashed to one, resized, centre-cropped, RGB scaled to [0, 1]. The network normalises with `mean` and `std` itself (inside the Lightning module and
the ONNX graph). Training augments the same ROI its own way; evaluation, the export's parity check and
the onnxruntime classifier all run `Preprocessing.to_input`, NumPy and OpenCV only.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.errors import VehlocError

COLOUR_ORDER = "RGB"
INPUT_RANGE = (0.0, 1.0)
PAD_GREY = 128
"""The grey of the bars that pad a ROI to a square when its aspect is kept."""


class ImageInputError(VehlocError):
    """An image is missing, cannot be decoded, or is not a usable colour image."""


JPEG_START = b"\xff\xd8"
JPEG_END = b"\xff\xd9"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_END = b"IEND\xaeB`\x82"
DECODER_WARNINGS = ("Corrupt JPEG data", "Premature end of JPEG file", "libpng error", "libpng warning")


def truncation_problem(data: bytes) -> str | None:
    """Why an encoded image is incomplete, or None: a JPEG must end with its end-of-image marker FF D9 (after
    any zero padding), a PNG with its IEND chunk. Decoders fill the missing part of a truncated file with grey
    and only print a warning, so a cut download would otherwise be classified as if it were whole."""
    if data.startswith(JPEG_START):
        if not data.rstrip(b"\x00").endswith(JPEG_END):
            return "truncated JPEG: it does not end with the end-of-image marker FF D9"
    elif data.startswith(PNG_SIGNATURE):
        if not data.rstrip(b"\x00").endswith(PNG_END):
            return "truncated PNG: it does not end with the IEND chunk"
    return None


@contextmanager
def _captured_stderr() -> Iterator[list[str]]:
    """What native code (libjpeg, libpng) writes to the process's stderr inside the block, collected into the
    yielded list when the block ends (file descriptor 2 goes to a temporary file meanwhile)."""
    messages: list[str] = []
    sys.stderr.flush()
    with tempfile.TemporaryFile() as capture:
        saved = os.dup(2)
        os.dup2(capture.fileno(), 2)
        try:
            yield messages
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            capture.seek(0)
            messages.extend(capture.read().decode("utf-8", "replace").splitlines())


def decode_image(data: bytes, source: str, strict: bool = False) -> np.ndarray:
    """Encoded image bytes as a BGR uint8 (H, W, 3) array; ImageInputError naming `source` when they are not a
    decodable image or a truncated one. `strict` also fails on a warning of the JPEG or PNG decoder (corrupt
    data it decoded around)."""
    problem = truncation_problem(data)
    if problem:
        raise ImageInputError(f"{source}: {problem}")
    buffer = np.frombuffer(data, np.uint8)
    if strict:
        with _captured_stderr() as messages:
            image = cv2.imdecode(buffer, cv2.IMREAD_COLOR)
        warnings = [m.strip() for m in messages if m.strip().startswith(DECODER_WARNINGS)]
        if image is not None and warnings:
            raise ImageInputError(f"{source}: corrupt image data (the decoder says: {warnings[0]})")
    else:
        image = cv2.imdecode(buffer, cv2.IMREAD_COLOR)
    if image is None:
        raise ImageInputError(f"{source}: not a readable image")
    return image


def read_bgr(path: str | Path, strict: bool = False) -> np.ndarray:
    """An image file as a BGR uint8 (H, W, 3) array (alpha dropped, grey expanded); ImageInputError naming the
    file when it is missing, not a decodable image, or truncated (see `decode_image`; `strict` also fails on
    the decoder's warnings)."""
    path = Path(path)
    if not path.is_file():
        raise ImageInputError(f"{path}: image does not exist" + (" (it is a folder)" if path.is_dir() else ""))
    try:
        data = path.read_bytes()
    except OSError as err:
        raise ImageInputError(f"{path}: cannot be read ({err.strerror})") from None
    return decode_image(data, str(path), strict)


def enlarged_roi(image: np.ndarray, box: Box, enlarge_fraction: float) -> np.ndarray:
    """The part of `image` under `box` grown by `enlarge_fraction` of its size on each side (clipped to the
    image); ValueError when the box lies outside the image."""
    height_px, width_px = image.shape[:2]
    return box.enlarged(enlarge_fraction, width_px, height_px).crop(image)


def padded_square(roi_bgr: np.ndarray) -> np.ndarray:
    """The ROI centred on a square of `PAD_GREY` as wide as its longer side (returned as is when square)."""
    height_px, width_px = roi_bgr.shape[:2]
    side_px = max(height_px, width_px)
    if height_px == width_px:
        return roi_bgr
    top, left = (side_px - height_px) // 2, (side_px - width_px) // 2
    return cv2.copyMakeBorder(roi_bgr, top, side_px - height_px - top, left, side_px - width_px - left,
                              cv2.BORDER_CONSTANT, value=(PAD_GREY, PAD_GREY, PAD_GREY))


@dataclass(frozen=True)
class Preprocessing:
    """How a vehicle ROI becomes the classifier's input (stored in checkpoints and ONNX metadata)."""

    input_size_px: int
    resize_px: int
    roi_enlarge_fraction: float
    mean: tuple[float, float, float]
    std: tuple[float, float, float]
    keep_aspect: bool = False

    def __post_init__(self) -> None:
        if not (isinstance(self.input_size_px, int) and self.input_size_px >= 8):
            raise ValueError(f"input_size_px must be an integer >= 8, got {self.input_size_px!r}")
        if not (isinstance(self.resize_px, int) and self.resize_px >= self.input_size_px):
            raise ValueError(f"resize_px must be an integer >= input_size_px ({self.input_size_px}), got {self.resize_px!r}")
        if not 0.0 <= self.roi_enlarge_fraction <= 1.0:
            raise ValueError(f"roi_enlarge_fraction must lie in [0, 1], got {self.roi_enlarge_fraction!r}")
        if not isinstance(self.keep_aspect, bool):
            raise ValueError(f"keep_aspect must be true or false, got {self.keep_aspect!r}")
        if len(self.mean) != 3 or len(self.std) != 3 or min(self.std) <= 0:
            raise ValueError(f"mean and std need 3 values each, std positive; got {self.mean!r}, {self.std!r}")
        object.__setattr__(self, "mean", tuple(float(v) for v in self.mean))
        object.__setattr__(self, "std", tuple(float(v) for v in self.std))

    @property
    def colour_order(self) -> str:
        return COLOUR_ORDER

    @property
    def input_range(self) -> tuple[float, float]:
        return INPUT_RANGE

    def roi(self, image_bgr: np.ndarray, box: Box) -> np.ndarray:
        """The vehicle ROI: `box` grown by `roi_enlarge_fraction` on each side, clipped to the image."""
        return enlarged_roi(image_bgr, box, self.roi_enlarge_fraction)

    def to_input(self, roi_bgr: np.ndarray) -> np.ndarray:
        """Pad to a square (`keep_aspect`), resize to a `resize_px` square (area averaging when shrinking,
        bilinear when enlarging), centre-crop `input_size_px`, RGB float32 in [0, 1], (3, S, S)."""
        if self.keep_aspect:
            roi_bgr = padded_square(roi_bgr)
        height_px, width_px = roi_bgr.shape[:2]
        shrinking = self.resize_px < min(height_px, width_px)
        square = cv2.resize(roi_bgr, (self.resize_px, self.resize_px),
                            interpolation=cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR)
        offset = int(round((self.resize_px - self.input_size_px) / 2.0))
        crop = square[offset:offset + self.input_size_px, offset:offset + self.input_size_px]
        rgb = cv2.cvtColor(crop, cv2.COLOR_BGR2RGB)
        return np.ascontiguousarray(rgb.transpose(2, 0, 1), dtype=np.float32) / 255.0

    def as_dict(self) -> dict[str, object]:
        return {**asdict(self), "mean": list(self.mean), "std": list(self.std)}

    @classmethod
    def from_dict(cls, values: dict[str, object]) -> Preprocessing:
        """From `as_dict`'s mapping; ValueError naming a missing or bad entry (`keep_aspect` may be missing:
        files written before it squashed the ROI)."""
        fields = ("input_size_px", "resize_px", "roi_enlarge_fraction", "mean", "std")
        missing = [name for name in fields if name not in values]
        if missing:
            raise ValueError(f"preprocessing lacks {', '.join(missing)}")
        return cls(int(values["input_size_px"]), int(values["resize_px"]), float(values["roi_enlarge_fraction"]),
                   tuple(values["mean"]), tuple(values["std"]), values.get("keep_aspect", False))
