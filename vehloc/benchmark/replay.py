"""A benchmark run's stop records made again from their captured inputs (`capture=` of the benchmark): each case's
stop record's inputs after the classification (`RecordInputs`: its ROI, silhouette, calibration, predicted model and
vote, travel and key-point inputs) are written beside its row. `replay` makes the paper's estimate from them again
with other detector settings and scores it as the run did: nothing is rendered, tracked or fitted, so a sweep of
plate, wheel or footprint settings over 200 cases takes seconds, the model fit's columns staying the captured run's.
With `refit`, the whole record is made again (`record_of`: the paper's box, the model fit and its starts, the
status), so fit and pipeline settings replay too, in the fits' time alone. Its `cases.csv` compares case by case
with another replay (`vehloc.benchmark.paired`).

A capture is a pickle, read back only by the same version of vehloc that wrote it: a cache of one run, not an
exchange format, and like any pickle only to be opened where it was made."""

from __future__ import annotations

import pickle
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vehloc.atomic import write_bytes
from vehloc.benchmark.cases import BenchmarkCase
from vehloc.benchmark.runner import errors, record_columns, true_box
from vehloc.benchmark.side_by_side import in_order
from vehloc.errors import DataError
from vehloc.geometry.outcome import NotPlaced
from vehloc.geometry.pipeline.key_points import paper_estimate
from vehloc.geometry.pipeline.localize import RecordInputs, record_of
from vehloc.geometry.pipeline.settings import LocalizeSettings

CAPTURE_FORMAT = 2
"""Bumped whenever what a capture holds changes: an older capture is refused, not misread."""
PAPER_COLUMNS = ("key_point", "paper_position_pct", "paper_heading_deg", "paper_position_mm", "paper_within")
"""The row's columns a replay of the key points makes again; every other column is the captured run's."""
RECORD_COLUMNS = ("status", "reason_code", "reason", "notes", "localized", "frame", "predicted_model", "correct",
                  *PAPER_COLUMNS, "fit_position_pct", "fit_heading_deg", "fit_position_mm", "fit_within", "fit_iou",
                  "fit_start", "fit_sigma_position_mm", "fit_sigma_heading_deg")
"""The row's columns a replay of the whole record (`refit`) makes again."""


@dataclass(frozen=True, eq=False)
class CapturedCase:
    """One benchmark case as its run left it: its split, the drawn case, its row (`run_case`) and what its stop record
    was made from after the classification (None where the case has no stop record or it was not classified)."""

    split: str
    case: BenchmarkCase
    row: dict[str, Any]
    inputs: RecordInputs | None


def capture_path(folder: Path, split: str, seed: int) -> Path:
    """Where a case's capture is written in a capture folder."""
    return Path(folder) / f"{split}_{seed}.pkl"


def write_capture(folder: Path, captured: CapturedCase) -> Path:
    """Write one case's capture into `folder` (atomically: a run stopped halfway leaves whole files only)."""
    path = capture_path(folder, captured.split, captured.case.seed)
    return write_bytes(path, pickle.dumps((CAPTURE_FORMAT, captured), protocol=pickle.HIGHEST_PROTOCOL))


def read_capture(path: Path) -> CapturedCase:
    """One capture file; DataError naming it when it cannot be read as one written by this version."""
    try:
        with open(path, "rb") as file:
            loaded = pickle.load(file)
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError, TypeError) as err:
        raise DataError(f"{path}: not a benchmark capture ({type(err).__name__}: {err})") from None
    if not (isinstance(loaded, tuple) and len(loaded) == 2 and loaded[0] == CAPTURE_FORMAT
            and isinstance(loaded[1], CapturedCase)):
        raise DataError(f"{path}: not a capture of this version of vehloc (format {CAPTURE_FORMAT}); "
                        f"capture the run again (capture=DIR)")
    return loaded[1]


def read_captures(folder: str | Path) -> list[CapturedCase]:
    """Every capture in `folder`, in split and seed order; DataError naming the folder when it holds none."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError(f"{folder}: no such folder (a benchmark run's capture=DIR)")
    paths = sorted(folder.glob("*_*.pkl"))
    if not paths:
        raise DataError(f"{folder}: holds no capture (<split>_<seed>.pkl files of a run with capture=DIR)")
    captured = [read_capture(path) for path in paths]
    return sorted(captured, key=lambda c: (c.split, c.case.seed))


def replayed_row(captured: CapturedCase, settings: LocalizeSettings, refit: bool = False) -> dict[str, Any]:
    """The case's row with the paper's estimate made again from its inputs with `settings` (its detectors and the
    pipeline's turning of the placement into the paper's box) and scored against the truth; without one, no paper
    columns but an empty key point (as a run's row). With `refit`, the whole stop record made again (`record_of`) and
    its columns (`RECORD_COLUMNS`) scored as a run scores them. A case without inputs (no stop record, or none
    classified) keeps its captured row."""
    if captured.inputs is None:
        return dict(captured.row)
    pipeline = settings.pipeline
    placement = paper_estimate(captured.inputs.key_points, settings.detectors, pipeline.wheels_at_axles,
                               pipeline.max_key_points_path_gap_deg)
    if refit:
        return replaced(captured.row, RECORD_COLUMNS,
                        record_columns(captured.case, record_of(captured.inputs, placement, settings)))
    if isinstance(placement, NotPlaced):
        return replaced(captured.row, PAPER_COLUMNS, {"key_point": ""})
    return replaced(captured.row, PAPER_COLUMNS,
                    {"key_point": placement.kind} | errors("paper", placement.box, true_box(captured.case)))


def replaced(row: dict[str, Any], dropped: tuple[str, ...], made: dict[str, Any]) -> dict[str, Any]:
    """`row` without its `dropped` columns, the `made` ones in their place (new ones after)."""
    return {key: value for key, value in row.items() if key not in dropped or key in made} | made


def replay(captures: Iterable[CapturedCase], settings: LocalizeSettings, refit: bool = False,
           workers: int = 1) -> list[dict[str, Any]]:
    """Every captured case's replayed row (`replayed_row`), in the order given, `workers` side by side."""
    return list(in_order(replayed_row, [(captured, settings, refit) for captured in captures], workers))
