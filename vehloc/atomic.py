"""Outputs that appear whole or not at all, and outputs checked before any work starts.

Each file is written to a temporary sibling and renamed over its target only when complete, so an interrupt
or a failure leaves the previous file as it was; a set of files that belong together (a scene's video, truth
and site) is renamed into place only when every one of them is complete; a folder (the demo set, a Table 1
folder) is built as a temporary sibling folder and swapped in whole. Temporary siblings are named
`.<name>.<pid>.tmp`; one left behind by a killed process is removed by the next write of the same target.
`check_output_file` and `check_output_dir` say before the work whether an output can be written where it is
asked for."""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np

from vehloc.errors import VehlocError


class OutputError(VehlocError):
    """An output cannot be written where it is asked for."""


def temporary_sibling(path: Path, suffix: str = "") -> Path:
    """`.<name>.<pid>.tmp<suffix>` beside `path`: on the same file system, so the rename is atomic."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp{suffix}")


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_siblings(path: Path) -> list[Path]:
    """Remove the temporary siblings of `path` (`.<name>.<pid>.tmp*`, `.<name>.<pid>.old`) that processes no
    longer running left behind; return them."""
    path = Path(path)
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.(tmp.*|old)$")
    removed = []
    try:
        siblings = list(path.parent.iterdir())
    except OSError:
        return removed
    for sibling in siblings:
        match = pattern.match(sibling.name)
        if not match or int(match.group(1)) == os.getpid() or _process_alive(int(match.group(1))):
            continue
        _remove(sibling)
        removed.append(sibling)
    return removed


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


@contextmanager
def atomic_path(path: str | Path, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary sibling of `path` (ending in `suffix`, for writers that pick the format by it) to
    write to; it replaces `path` when the block completes and is removed when it fails."""
    with atomic_paths([path], suffix) as (temporary,):
        yield temporary


@contextmanager
def atomic_paths(paths: Sequence[str | Path], suffix: str = "") -> Iterator[tuple[Path, ...]]:
    """Yield a temporary sibling for each of several files that belong together; they replace their targets
    one right after the other when the block completes (none of them before), and are removed when it fails."""
    targets = [Path(p) for p in paths]
    for target in targets:
        target.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_siblings(target)
    temporaries = tuple(temporary_sibling(t, suffix) for t in targets)
    try:
        yield temporaries
        for temporary, target in zip(temporaries, targets):
            os.replace(temporary, target)
    finally:
        for temporary in temporaries:
            _remove(temporary)


@contextmanager
def atomic_dir(path: str | Path) -> Iterator[Path]:
    """Yield an empty temporary sibling folder of `path` to build a folder in; when the block completes it
    takes the place of `path` (an earlier folder there is removed only then), when it fails it is removed and
    `path` is left as it was."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_siblings(path)
    temporary = temporary_sibling(path)
    _remove(temporary)
    temporary.mkdir()
    old = path.with_name(f".{path.name}.{os.getpid()}.old")
    try:
        yield temporary
        if path.is_dir() and not path.is_symlink():
            os.replace(path, old)
        elif path.exists() or path.is_symlink():
            raise OutputError(f"{path}: exists and is not a folder")
        os.replace(temporary, path)
    finally:
        _remove(temporary)
        _remove(old)


def write_text(path: str | Path, text: str) -> Path:
    """Write a UTF-8 text file atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write a file atomically."""
    with atomic_path(path) as temporary:
        temporary.write_bytes(data)
    return Path(path)


def encode_image(path: str | Path, image: np.ndarray) -> bytes:
    """An image encoded in the format of the suffix of `path`; OutputError when OpenCV has no such format."""
    path = Path(path)
    try:
        ok, encoded = cv2.imencode(path.suffix or ".png", image)
    except cv2.error:
        ok = False
    if not ok:
        raise OutputError(f"{path}: OpenCV cannot encode an image as {path.suffix!r}")
    return encoded.tobytes()


def write_image(path: str | Path, image: np.ndarray) -> Path:
    """Write an image file (format from the suffix) atomically."""
    return write_bytes(path, encode_image(path, image))


def _nearest_existing(path: Path) -> Path:
    path = path.absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def _check_writable_folder(folder: Path, for_what: Path, what: str) -> None:
    """OutputError unless files can be created in `folder` (or, when it does not exist yet, in the folder it
    would be created in): tried by creating and removing a file, so that permissions, read-only file systems
    and full disks all show."""
    existing = _nearest_existing(folder)
    if not existing.is_dir():
        raise OutputError(f"{what} {for_what}: {existing} is a file, not a folder")
    try:
        with tempfile.TemporaryFile(dir=existing, prefix=".vehloc-write-test-"):
            pass
    except OSError as err:
        raise OutputError(f"{what} {for_what}: cannot write in {existing} ({err.strerror})") from None


def check_output_file(path: str | Path, what: str = "output", inputs: Sequence[str | Path] = ()) -> Path:
    """OutputError (naming `what` and the path) unless a file can be written at `path`: not a folder, not one of
    the run's `inputs` (a tool never writes over what it reads), in a folder that exists or can be created, and
    that can be written to."""
    text, path = str(path), Path(path)
    if path.is_dir() or text.endswith(os.sep) or not path.name:
        raise OutputError(f"{what} {text}: is a folder; give a file name")
    if any(Path(source).resolve() == path.resolve() for source in inputs):
        raise OutputError(f"{what} {text}: is an input this run reads; write the output elsewhere")
    _check_writable_folder(path.parent, path, what)
    return path


def check_output_dir(path: str | Path, what: str = "output folder") -> Path:
    """OutputError unless `path` is a folder, or can be created as one, that can be written to."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"{what} {path}: is a file, not a folder")
    _check_writable_folder(path, path, what)
    return path


def check_output_image(path: str | Path, what: str = "output") -> Path:
    """`check_output_file`, and OutputError unless OpenCV can write an image in the format of the suffix."""
    path = check_output_file(path, what)
    try:
        encode_image(path, np.zeros((1, 1, 3), np.uint8))
    except OutputError:
        raise OutputError(f"{what} {path}: OpenCV cannot write {path.suffix!r} images; use .png or .jpg") from None
    return path
