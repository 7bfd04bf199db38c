"""The CompCars `misc/make_model_name.mat` file: MATLAB cell arrays of make and model names."""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vehloc.errors import DataError

_FIXED_HEADER = b"MATLAB 5.0 MAT-file, written by vehloc"
_HEADER_TEXT_BYTES = 116


def _cell_to_names(cell: np.ndarray) -> dict[int, str]:
    """Map 1-based ids to names; empty cells (unnamed ids) are skipped."""
    names = {}
    for i, item in enumerate(np.asarray(cell, dtype=object).ravel(), start=1):
        values = np.asarray(item).ravel()
        if values.size and str(values[0]).strip():
            names[i] = str(values[0]).strip()
    return names


def read_make_model_names(path: Path) -> tuple[dict[int, str], dict[int, str]]:
    """Read `make_names` and `model_names` as {1-based id: name}."""
    import scipy.io  # on first use: a refused CLI answers sooner

    try:
        content = scipy.io.loadmat(str(path))
    except Exception as exc:  # scipy raises several unrelated types for corrupt files
        raise DataError(f"{path}: not a readable MATLAB file ({exc})") from None
    missing = [key for key in ("make_names", "model_names") if key not in content]
    if missing:
        raise DataError(f"{path}: missing variable(s) {', '.join(missing)}")
    return _cell_to_names(content["make_names"]), _cell_to_names(content["model_names"])


def _as_cell(names: Sequence[str]) -> np.ndarray:
    cell = np.empty((len(names), 1), dtype=object)
    for i, name in enumerate(names):
        cell[i, 0] = name
    return cell


def write_make_model_names(path: Path, make_names: Sequence[str], model_names: Sequence[str]) -> None:
    """Write the names as MATLAB cell arrays; the same names always give the same bytes."""
    import scipy.io  # on first use: a refused CLI answers sooner

    buffer = io.BytesIO()
    scipy.io.savemat(buffer, {"make_names": _as_cell(make_names), "model_names": _as_cell(model_names)})
    data = bytearray(buffer.getvalue())
    data[:_HEADER_TEXT_BYTES] = _FIXED_HEADER.ljust(_HEADER_TEXT_BYTES, b" ")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(bytes(data))
