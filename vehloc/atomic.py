"""Outputs that appear whole or not at all: each file is written to a temporary sibling and renamed over
its target only when complete, so an interrupt or a failure leaves the previous file as it was."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np

from vehloc.errors import VehlocError


def temporary_sibling(path: Path) -> Path:
    """`.<name>.<pid>.tmp` beside `path`: on the same file system, so the rename is atomic."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary sibling of `path` to write to; it replaces `path` when the block completes and is
    removed when it fails."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = temporary_sibling(path)
    try:
        yield temporary
        os.replace(temporary, path)
    finally:
        if temporary.is_dir():
            shutil.rmtree(temporary, ignore_errors=True)
        else:
            temporary.unlink(missing_ok=True)


def write_text(path: str | Path, text: str) -> Path:
    """Write a UTF-8 text file atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
    return Path(path)


def write_image(path: str | Path, image: np.ndarray) -> Path:
    """Write an image file (format from the suffix) atomically."""
    path = Path(path)
    ok, encoded = cv2.imencode(path.suffix or ".png", image)
    if not ok:
        raise VehlocError(f"{path}: OpenCV cannot encode an image as {path.suffix!r}")
    with atomic_path(path) as temporary:
        temporary.write_bytes(encoded.tobytes())
    return path
