"""The optional CompCars `misc/attributes.txt` table of per-model attributes."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from vehloc.data.text import read_text
from vehloc.errors import DataError

HEADER = ("model_id", "maximum_speed", "displacement", "door_number", "seat_number", "type")
TYPE_NAMES: dict[int, str] = {
    1: "MPV", 2: "SUV", 3: "sedan", 4: "hatchback", 5: "minibus", 6: "fastback", 7: "estate",
    8: "pickup", 9: "sports", 10: "crossover", 11: "convertible", 12: "hardtop convertible",
}


@dataclass(frozen=True)
class ModelAttributes:
    """CompCars attributes of one model; 0 means unknown, as in the original file."""

    model_id: int
    maximum_speed_kmh: float
    displacement_l: float
    door_number: int
    seat_number: int
    type_code: int


def read_attributes(path: Path) -> dict[int, ModelAttributes]:
    """Read attributes.txt (header line, then one whitespace-separated row per model)."""
    rows: dict[int, ModelAttributes] = {}
    problems = []
    for line_no, raw in enumerate(read_text(path).splitlines(), start=1):
        fields = raw.split()
        if not fields or (line_no == 1 and fields[0] == HEADER[0]):
            continue
        try:
            if len(fields) != len(HEADER):
                raise ValueError(f"expected {len(HEADER)} fields {' '.join(HEADER)}, got {len(fields)}")
            row = ModelAttributes(
                int(fields[0]), float(fields[1]), float(fields[2]),
                int(fields[3]), int(fields[4]), int(fields[5]),
            )
        except ValueError as exc:
            problems.append(f"{path}:{line_no}: {exc}")
            continue
        if row.model_id in rows:
            problems.append(f"{path}:{line_no}: model {row.model_id} listed twice")
        rows[row.model_id] = row
    if problems:
        raise DataError(f"{path}: malformed attributes", problems)
    return rows


def write_attributes(path: Path, rows: Sequence[ModelAttributes]) -> None:
    """Write attributes.txt in the CompCars format."""
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [" ".join(HEADER)] + [
        f"{r.model_id} {r.maximum_speed_kmh:g} {r.displacement_l:g} {r.door_number} "
        f"{r.seat_number} {r.type_code}"
        for r in rows
    ]
    path.write_text("\n".join(lines) + "\n")
