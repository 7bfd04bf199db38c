"""The one way vehloc reads a text file (split lists, labels, specs.csv, attributes.txt, site files, JSON):
UTF-8, with or without a byte-order mark; a file in another encoding (Latin-1 from a spreadsheet) or a binary
file is named with the byte offset and line where it stops being UTF-8 text."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from vehloc.errors import DataError, VehlocError

UTF8_BOM = b"\xef\xbb\xbf"


class TextFileError(DataError):
    """A text file is missing, unreadable, not UTF-8 text, or not the JSON or YAML it should be."""


def decode_text(data: bytes, source: str, error: type[VehlocError] = TextFileError) -> str:
    """UTF-8 bytes as text (a leading byte-order mark dropped); `error` naming `source`, the byte offset and the
    line when they are not UTF-8 text or hold a NUL byte (a binary file)."""
    start = len(UTF8_BOM) if data.startswith(UTF8_BOM) else 0
    try:
        text = data[start:].decode("utf-8")
    except UnicodeDecodeError as err:
        offset = start + err.start
        line = data[:offset].count(b"\n") + 1
        raise error(
            f"{source}: not UTF-8 text: byte 0x{data[offset]:02x} at offset {offset} (line {line}) is not valid "
            "UTF-8; save the file as UTF-8"
        ) from None
    nul = text.find("\x00")
    if nul >= 0:
        offset = start + len(text[:nul].encode("utf-8"))
        raise error(f"{source}: a binary file, not text (NUL byte at offset {offset})")
    return text


def read_text(path: str | Path, error: type[VehlocError] = TextFileError) -> str:
    """A UTF-8 text file's content (see `decode_text`); `error` naming the file when it is missing, a folder,
    unreadable or not text."""
    path = Path(path)
    if not path.exists():
        raise error(f"{path}: file does not exist")
    if path.is_dir():
        raise error(f"{path}: is a folder, not a file")
    try:
        data = path.read_bytes()
    except OSError as err:
        raise error(f"{path}: cannot be read ({err.strerror})") from None
    return decode_text(data, str(path), error)


def read_json(path: str | Path, error: type[VehlocError] = TextFileError) -> Any:
    """A JSON file's content; `error` naming the file (and line) when it is not UTF-8 text or not JSON."""
    text = read_text(path, error)
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise error(f"{path}: not a JSON file ({err.msg} at line {err.lineno}, column {err.colno})") from None


def read_yaml(path: str | Path, error: type[VehlocError] = TextFileError) -> Any:
    """A YAML file's content (safe loader); `error` naming the file (and line) when it is not UTF-8 text or not
    YAML."""
    text = read_text(path, error)
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or type(err).__name__
        raise error(f"{path}: not valid YAML ({problem}{where})") from None
