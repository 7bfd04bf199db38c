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
    """A video's frame size, frame count (as its container says) and frame rate."""

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
        return VideoInfo(frame.shape[1], frame.shape[0], int(capture.get(cv2.CAP_PROP_FRAME_COUNT)),
                         float(capture.get(cv2.CAP_PROP_FPS)))


def iter_frames(path: Path | str) -> Iterator[np.ndarray]:
    """Yield the BGR frames of a video (FFmpeg backend); MediaError if it does not exist or yields no frame."""
    with _opened(path) as (capture, frame):
        ok = True
        while ok:
            yield frame
            ok, frame = capture.read()


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
