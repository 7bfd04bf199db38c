"""The vehicle specifications table: model id -> length, width, height (and wheelbase) in mm."""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vehloc.data.text import read_text
from vehloc.errors import DataError

REQUIRED_COLUMNS = ("model_id", "make", "model", "length_mm", "width_mm", "height_mm")
COLUMNS = REQUIRED_COLUMNS + ("wheelbase_mm",)
DIMENSION_NAMES = ("length", "width", "height")


def display_name(make: str, model: str) -> str:
    """`make model`, without repeating a make that the model name already starts with."""
    return model if model.startswith(make) else f"{make} {model}".strip()


@dataclass(frozen=True)
class VehicleSpec:
    """Published dimensions of one car model, in millimetres."""

    model_id: int
    make: str
    model: str
    length_mm: float
    width_mm: float
    height_mm: float
    wheelbase_mm: float | None = None

    @property
    def dims_mm(self) -> np.ndarray:
        """(length, width, height) in mm."""
        return np.array([self.length_mm, self.width_mm, self.height_mm], dtype=float)


class SpecsTable:
    """Validated specifications, looked up by model id."""

    def __init__(self, specs: Iterable[VehicleSpec], source: str = "<memory>") -> None:
        self.source = source
        self._by_id: dict[int, VehicleSpec] = {}
        for spec in specs:
            if spec.model_id in self._by_id:
                raise DataError(f"{source}: model {spec.model_id} listed twice")
            self._by_id[spec.model_id] = spec

    def __len__(self) -> int:
        return len(self._by_id)

    def __contains__(self, model_id: int) -> bool:
        return model_id in self._by_id

    def __getitem__(self, model_id: int) -> VehicleSpec:
        return self._by_id[model_id]

    @property
    def model_ids(self) -> list[int]:
        return sorted(self._by_id)

    def require(self, model_ids: Iterable[int], names: dict[int, str] | None = None) -> None:
        """Raise DataError listing every model id that has no dimensions."""
        missing = sorted(set(model_ids) - set(self._by_id))
        if missing:
            names = names or {}
            problems = [f"model {m}" + (f" ({names[m]})" if m in names else "") for m in missing]
            raise DataError(
                f"{self.source}: no dimensions for {len(missing)} class(es) of the data set", problems
            )

    def dims_mm(self, model_ids: Sequence[int]) -> np.ndarray:
        """(N, 3) array of length, width, height in mm for the given model ids."""
        self.require(model_ids)
        return np.array([self._by_id[m].dims_mm for m in model_ids], dtype=float).reshape(-1, 3)


def _positive_mm(value: str, column: str, where: str, problems: list[str]) -> float | None:
    try:
        number = float(value)
    except ValueError:
        problems.append(f"{where}: {column} {value!r} is not a number")
        return None
    if not number > 0:
        problems.append(f"{where}: {column} {value!r} must be positive")
        return None
    return number


def _parse_row(row: dict[str, str], where: str, problems: list[str]) -> VehicleSpec | None:
    before = len(problems)
    model_id_text = (row.get("model_id") or "").strip()
    if not model_id_text.isdigit():
        problems.append(f"{where}: model_id {model_id_text!r} is not a positive integer")
    dims = [
        _positive_mm((row.get(c) or "").strip(), c, where, problems)
        for c in ("length_mm", "width_mm", "height_mm")
    ]
    wheelbase_text = (row.get("wheelbase_mm") or "").strip()
    wheelbase = _positive_mm(wheelbase_text, "wheelbase_mm", where, problems) if wheelbase_text else None
    if wheelbase is not None and dims[0] is not None and wheelbase >= dims[0]:
        problems.append(f"{where}: wheelbase_mm {wheelbase:g} is not shorter than length_mm {dims[0]:g}")
    if len(problems) > before:
        return None
    length_mm, width_mm, height_mm = dims
    return VehicleSpec(
        int(model_id_text), (row.get("make") or "").strip(), (row.get("model") or "").strip(),
        length_mm, width_mm, height_mm, wheelbase,
    )


def read_specs_csv(path: Path | str) -> SpecsTable:
    """Read and validate a specs CSV (UTF-8, a byte-order mark accepted); raise DataError listing every problem
    with its line."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: specs table does not exist")
    with io.StringIO(read_text(path), newline="") as handle:
        reader = csv.DictReader(handle)
        missing = [c for c in REQUIRED_COLUMNS if c not in (reader.fieldnames or [])]
        if missing:
            raise DataError(f"{path}: missing column(s) {', '.join(missing)}")
        problems: list[str] = []
        specs: list[VehicleSpec] = []
        first_line: dict[int, int] = {}
        for row in reader:
            where = f"{path}:{reader.line_num}"
            spec = _parse_row(row, where, problems)
            if spec is None:
                continue
            if spec.model_id in first_line:
                problems.append(
                    f"{where}: model_id {spec.model_id} already given on line {first_line[spec.model_id]}"
                )
                continue
            first_line[spec.model_id] = reader.line_num
            specs.append(spec)
    if problems:
        raise DataError(f"{path}: {len(problems)} problem(s) in specs table", problems)
    return SpecsTable(specs, source=str(path))


def write_specs_csv(path: Path, specs: Sequence[VehicleSpec]) -> None:
    """Write specs as CSV with the columns of COLUMNS."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(COLUMNS)
        for s in specs:
            writer.writerow([
                s.model_id, s.make, s.model, f"{s.length_mm:g}", f"{s.width_mm:g}", f"{s.height_mm:g}",
                "" if s.wheelbase_mm is None else f"{s.wheelbase_mm:g}",
            ])
