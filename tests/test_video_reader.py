"""The video reader knows how many frames its container promises: a file cut short says where decoding stopped
(once its frames run out), a still image or a one-frame video is refused, and a container that states no count
is read to its end."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from vehloc.geometry.pipeline.video import MediaError, VideoFrames

FRAMES = 60


def _write_video(path: Path, frames: int) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (160, 120))
    rng = np.random.default_rng(0)
    for _ in range(frames):
        writer.write(rng.integers(0, 255, (120, 160, 3), dtype=np.uint8))
    writer.release()
    return path


def test_a_whole_video_ends_as_promised(tmp_path: Path) -> None:
    video = VideoFrames(_write_video(tmp_path / "whole.avi", FRAMES))
    assert video.info.frame_count == FRAMES and sum(1 for _ in video) == FRAMES
    assert video.early_end is None and video.frames_to_read(None) == FRAMES and video.frames_to_read(10) == 10


def test_a_video_cut_short_says_where_decoding_stopped(tmp_path: Path) -> None:
    data = _write_video(tmp_path / "whole.avi", FRAMES).read_bytes()
    cut = tmp_path / "cut.avi"
    cut.write_bytes(data[: len(data) // 2])  # the header still promises 60 frames
    video = VideoFrames(cut)
    frames = iter(video)
    next(frames)
    assert video.early_end is None  # not judged while frames remain
    decoded = 1 + sum(1 for _ in frames)
    assert 20 <= decoded <= 40
    assert video.early_end == (f"{cut}: decoding stopped at frame {decoded} of the {FRAMES} its container promises "
                               f"(the file is cut short or corrupt there); frames 0-{decoded - 1} were read")


@pytest.mark.parametrize("kind", ["one_frame_video", "png", "png_named_avi"])
def test_a_still_image_is_not_a_video(kind: str, tmp_path: Path) -> None:
    if kind == "one_frame_video":
        path = _write_video(tmp_path / "one.avi", 1)
    else:
        path = tmp_path / ("still.png" if kind == "png" else "still.avi")
        ok, encoded = cv2.imencode(".png", np.zeros((120, 160, 3), np.uint8))
        path.write_bytes(encoded.tobytes())
    with pytest.raises(MediaError) as caught:
        VideoFrames(path)
    expected = "is an image, not a video" if kind == "png" else "holds 1 frame (a still image?); a video of at least 2"
    assert str(caught.value).startswith(f"{path}: {expected}")
