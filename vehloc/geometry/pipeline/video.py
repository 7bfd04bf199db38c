"""Reading frames from videos and images, with clear errors for files OpenCV cannot read."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # FFmpeg quiet: bad files are reported by vehloc, in one line

import cv2  # noqa: E402 (after the FFmpeg log level, which is read when its backend loads)
import numpy as np  # noqa: E402

from vehloc.data.preprocess import ImageInputError, read_bgr

VIDEO_SUFFIXES = {".avi", ".mp4", ".mkv", ".mov", ".m4v", ".mpg", ".mpeg", ".webm"}


class MediaError(ImageInputError):
    """A video cannot be read."""


@contextmanager
def _opencv_errors_only() -> Iterator[None]:
    previous = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(previous)


@dataclass(frozen=True)
class VideoInfo:
    """A video's frame size, frame count (as its container says; 0 where it does not) and frame rate."""

    width_px: int
    height_px: int
    frame_count: int
    fps: float


@contextmanager
def _opened(path: Path | str) -> Iterator[tuple[cv2.VideoCapture, np.ndarray]]:
    """The video opened with the FFmpeg backend and its first frame; MediaError if it does not exist or yields
    no frame."""
    path = Path(path)
    if not path.is_file():
        raise MediaError(f"{path}: video does not exist")
    with _opencv_errors_only():
        capture = cv2.VideoCapture(str(path), cv2.CAP_FFMPEG)
    try:
        ok, frame = capture.read()
        if not ok:
            raise MediaError(f"{path}: not a readable video (OpenCV decoded no frame)")
        yield capture, frame
    finally:
        capture.release()


def video_info(path: Path | str) -> VideoInfo:
    """The size, length and rate of a video; MediaError if it does not exist or OpenCV cannot open it."""
    with _opened(path) as (capture, frame):
        count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        return VideoInfo(frame.shape[1], frame.shape[0], max(count, 0), float(capture.get(cv2.CAP_PROP_FPS)))


def iter_frames(path: Path | str) -> Iterator[np.ndarray]:
    """Yield the BGR frames of a video (FFmpeg backend); MediaError if it does not exist or yields no frame."""
    with _opened(path) as (capture, frame):
        ok = True
        while ok:
            yield frame
            ok, frame = capture.read()


def _has_frames(path: Path, count: int) -> bool:
    """Whether the video decodes at least `count` frames (for a container that states fewer, or none)."""
    with _opened(path) as (capture, _):
        return all(capture.read()[0] for _ in range(count - 1))


IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".gif"}
MIN_VIDEO_FRAMES = 2
"""A localization's video has at least this many frames (the background model learns the road over frames)."""


def early_end_tolerance(promised: int) -> int:
    """How many frames fewer than its container promises a video may decode without being called cut short (a
    container's count from its duration may be off by one or two)."""
    return max(2, promised // 100)


class VideoFrames:
    """The frames of a video in order, knowing how many its container promises: iterate it; once the frames run
    out, `early_end` says in one line where decoding stopped when that is short of the promise (a truncated or
    partly corrupt file), None otherwise (or while frames remain). Refuses (MediaError) a file that is missing,
    an image, or a video of fewer than MIN_VIDEO_FRAMES frames."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        if self.path.suffix.lower() in IMAGE_SUFFIXES:
            raise MediaError(f"{self.path}: is an image, not a video")
        self.info = video_info(self.path)
        if self.info.frame_count < MIN_VIDEO_FRAMES and not _has_frames(self.path, MIN_VIDEO_FRAMES):
            raise MediaError(f"{self.path}: holds 1 frame (a still image?); a video of at least {MIN_VIDEO_FRAMES} "
                             "frames is needed (the background model learns the road over its frames)")
        self.decoded = 0
        self.early_end: str | None = None

    def frames_to_read(self, max_frames: int | None) -> int | None:
        """How many frames a run reads: the container's count, at most `max_frames` (None: no limit); None when
        neither says."""
        counts = [n for n in (self.info.frame_count or None, max_frames) if n is not None]
        return min(counts) if counts else None

    def __iter__(self) -> Iterator[np.ndarray]:
        self.decoded, self.early_end = 0, None
        for frame in iter_frames(self.path):
            self.decoded += 1
            yield frame
        promised = self.info.frame_count
        if promised and self.decoded < promised - early_end_tolerance(promised):
            self.early_end = (f"{self.path}: decoding stopped at frame {self.decoded} of the {promised} its container "
                              f"promises (the file is cut short or corrupt there); frames 0-{self.decoded - 1} were read")


def read_still(path: Path | str, frame_index: int = 0) -> np.ndarray:
    """An image file, or one frame of a video file; ImageInputError (MediaError for a video) naming the file
    when it cannot be read."""
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        return read_bgr(path)
    for index, frame in enumerate(iter_frames(path)):
        if index == frame_index:
            return frame
    raise MediaError(f"{path}: has no frame {frame_index} (only {index + 1} frames)")


def median_background(path: Path | str, frame_count: int, step: int = 10) -> np.ndarray:
    """Per-pixel median of `frame_count` frames taken every `step` frames: the scene without traffic."""
    frames = []
    for index, frame in enumerate(iter_frames(path)):
        if index % step == 0:
            frames.append(frame)
        if len(frames) == frame_count:
            break
    if len(frames) < frame_count:
        raise MediaError(f"{path}: has {len(frames)} frame(s) at step {step}, {frame_count} asked for the background")
    return np.median(np.stack(frames), axis=0).astype(np.uint8)
