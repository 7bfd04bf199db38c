"""Two runs of the localization benchmark on the same cases, compared case by case: per split and gate, the cases
each run passes, the ones gained and lost, and the exact McNemar test of whether the change moved the rate (only
the cases that changed sides carry evidence; a run of 200 cases moves by a few cases on chance alone); per error
column, how many cases got better and worse and the sign test on them; and the cases that changed."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.benchmark.report import GATES, rates
from vehloc.errors import DataError

DRAW_COLUMNS = ("model_id", "camera_name", "x_mm", "y_mm", "heading_deg")
"""What makes a case the same case in two runs: its seed drew the same car, camera and pose."""
ERROR_COLUMNS = ("fit_position_pct", "fit_heading_deg", "paper_position_pct", "paper_heading_deg")
SHOWN_COLUMNS = ("status", "key_point", *ERROR_COLUMNS)
"""Per changed case, each run's value of these beside each other."""
REQUIRED_COLUMNS = ("split", "seed", "model", "status", "key_point", *DRAW_COLUMNS, *GATES)
GROUP_COLUMNS = ("view", "colour_group", "distance_band", "model")
"""The groups whose gates a comparison gives before and after, where both runs' cases.csv hold the column."""
POOLED = "all"
"""The split name of the rows over every split's cases together."""
MOVE_TOLERANCE = 0.01
"""An error moved when it changed by more than this (per cent or deg): the CSV's three decimals are noise below."""
DRAW_TOLERANCE = 1e-3 + 1e-9
"""Pose columns agree within the CSV's rounding."""


@dataclass(frozen=True)
class GateChange:
    """One gate of one split in both runs: the rate over each run's own cases of the gate (per cent), the seeds
    it gained and lost among the cases in the gate in both, and the exact McNemar p-value of those."""

    split: str
    gate: str
    cases: int
    before_pct: float
    after_pct: float
    gained: tuple[int, ...]
    lost: tuple[int, ...]
    p_value: float


@dataclass(frozen=True)
class ErrorChange:
    """One error column of one split over the cases with a value in both runs: how many got better (smaller by
    more than `MOVE_TOLERANCE`) and worse, the median change (after - before) of those that moved (NaN: none) and
    the sign test's p-value."""

    split: str
    column: str
    cases: int
    better: int
    worse: int
    median_change: float
    p_value: float


@dataclass(frozen=True)
class Comparison:
    """Two runs compared: each gate and error column per split, the cases whose outcome changed (one row each,
    the runs' values in `<column>_before` and `<column>_after`), and each gate's rate per group (`group_rates`)."""

    gates: tuple[GateChange, ...]
    errors: tuple[ErrorChange, ...]
    changed: pd.DataFrame
    groups: pd.DataFrame


def sign_test_p(wins: int, losses: int) -> float:
    """The exact two-sided sign test of `wins` against `losses` (the binomial with p = 1/2 over their sum): the
    chance of a split at least this uneven were either side as likely; 1 with none of either. On the cases that
    changed sides of a gate it is the exact McNemar test."""
    if wins < 0 or losses < 0:
        raise ValueError(f"counts must be >= 0, got {wins} and {losses}")
    total = wins + losses
    if total == 0:
        return 1.0
    tail = sum(math.comb(total, k) for k in range(min(wins, losses) + 1)) / 2.0 ** total
    return min(1.0, 2.0 * tail)


def read_cases(path: str | Path) -> pd.DataFrame:
    """A run's `cases.csv` (or the run folder holding it); DataError naming the file when it is missing or lacks
    a column the comparison needs, or a seed is in it twice."""
    path = Path(path)
    csv = path / "cases.csv" if path.is_dir() else path
    if not csv.is_file():
        raise DataError(f"{csv}: no such file (a benchmark run's folder or its cases.csv)")
    try:
        frame = pd.read_csv(csv)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise DataError(f"{csv}: not a benchmark's cases.csv ({err})") from None
    missing = [column for column in REQUIRED_COLUMNS if column not in frame]
    if missing:
        raise DataError(f"{csv}: not a benchmark's cases.csv: no column {', '.join(missing)}")
    twice = frame["seed"][frame["seed"].duplicated()]
    if len(twice):
        raise DataError(f"{csv}: seed {int(twice.iloc[0])} is in it twice")
    for column in ERROR_COLUMNS:
        if column not in frame:
            frame[column] = np.nan  # no case of the run had that method's estimate
    return frame.set_index("seed", drop=False).rename_axis(None)


def check_same_cases(before: pd.DataFrame, after: pd.DataFrame, names: tuple[str, str]) -> None:
    """DataError unless both runs hold the same seeds, each drawn as the same case (`DRAW_COLUMNS`)."""
    only_before, only_after = before.index.difference(after.index), after.index.difference(before.index)
    if len(only_before) or len(only_after):
        side, seeds = (names[0], only_before) if len(only_before) else (names[1], only_after)
        raise DataError(f"{side}: holds {len(seeds)} seed(s) the other run does not (first {int(seeds[0])}); "
                        f"compare runs of the same split and number of cases")
    after = after.loc[before.index]
    for column in DRAW_COLUMNS:
        if pd.api.types.is_numeric_dtype(before[column]) and pd.api.types.is_numeric_dtype(after[column]):
            differs = ~np.isclose(before[column], after[column], rtol=0.0, atol=DRAW_TOLERANCE)
        else:
            differs = before[column].astype(str).to_numpy() != after[column].astype(str).to_numpy()
        if differs.any():
            seed = int(before.index[np.argmax(differs)])
            raise DataError(f"{names[1]}: seed {seed} is not the case of {names[0]} ({column} "
                            f"{after.at[seed, column]} against {before.at[seed, column]}): the runs drew their "
                            f"cases with different settings")


def rate_pct(flags: np.ndarray) -> float:
    """The share (per cent) of the known flags (1 or 0; NaN: not in the gate's cases) that are 1; NaN with none."""
    known = flags[~np.isnan(flags)]
    return 100.0 * float(known.mean()) if len(known) else np.nan


def gate_flips(before: np.ndarray, after: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per case, from a gate's flags in both runs (1 or 0; NaN: not in its cases), whether it gained the gate (failed
    it before, passed after) and whether it lost it; neither where it is not in the gate's cases in both runs."""
    return (before < 0.5) & (after >= 0.5), (before >= 0.5) & (after < 0.5)


def gate_change(split: str, gate: str, before: pd.DataFrame, after: pd.DataFrame) -> GateChange:
    """One gate over one split's cases (the same seeds in the same order in both frames)."""
    b, a = before[gate].to_numpy(dtype=float), after[gate].to_numpy(dtype=float)
    both = ~np.isnan(b) & ~np.isnan(a)
    seeds = before.index.to_numpy()
    gained, lost = (tuple(int(s) for s in seeds[flips]) for flips in gate_flips(b, a))
    return GateChange(split, gate, int(both.sum()), rate_pct(b), rate_pct(a), gained, lost,
                      sign_test_p(len(gained), len(lost)))


def error_change(split: str, column: str, before: pd.DataFrame, after: pd.DataFrame) -> ErrorChange:
    """One error column over one split's cases with a value in both runs."""
    change = (after[column] - before[column]).dropna().to_numpy(dtype=float)
    moved = change[np.abs(change) > MOVE_TOLERANCE]
    better, worse = int((moved < 0).sum()), int((moved > 0).sum())
    return ErrorChange(split, column, len(change), better, worse, float(np.median(moved)) if len(moved) else np.nan,
                       sign_test_p(better, worse))


def changed_cases(before: pd.DataFrame, after: pd.DataFrame) -> pd.DataFrame:
    """The cases whose status, key point or a gate changed, or an error moved by more than `MOVE_TOLERANCE`: what
    each case is, then each shown column before and after, then per gate `gained`, `lost` or blank."""
    moved = np.zeros(len(before), dtype=bool)
    for column in ("status", "key_point"):
        moved |= before[column].fillna("").astype(str).to_numpy() != after[column].fillna("").astype(str).to_numpy()
    for column in GATES:
        b, a = before[column].to_numpy(dtype=float), after[column].to_numpy(dtype=float)
        moved |= ~((b == a) | (np.isnan(b) & np.isnan(a)))
    for column in ERROR_COLUMNS:
        b, a = before[column].to_numpy(dtype=float), after[column].to_numpy(dtype=float)
        moved |= (np.abs(a - b) > MOVE_TOLERANCE) | (np.isnan(a) != np.isnan(b))
    rows = pd.DataFrame({"split": before["split"], "seed": before["seed"], "model": before["model"],
                         "camera_name": before["camera_name"]})
    for column in SHOWN_COLUMNS:
        rows[f"{column}_before"], rows[f"{column}_after"] = before[column], after[column]
    for gate in GATES:
        gained, lost = gate_flips(before[gate].to_numpy(dtype=float), after[gate].to_numpy(dtype=float))
        rows[gate] = np.where(gained, "gained", np.where(lost, "lost", ""))
    return rows[moved].reset_index(drop=True)


def split_parts(cases: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """A run's cases per split (in their order), and all of them (`POOLED`) where it holds more than one split."""
    parts = [(str(split), part) for split, part in cases.groupby("split", sort=False)]
    return parts + [(POOLED, cases)] if len(parts) > 1 else parts


def group_rates(before: pd.DataFrame, after: pd.DataFrame) -> pd.DataFrame:
    """Per split (`split_parts`), group column (`GROUP_COLUMNS` that both runs hold) and group: the group's cases
    and each gate's rate (per cent of the group's cases in the gate) before and after, in `<gate>_before_pct` and
    `<gate>_after_pct`. The same cases in the same order in both frames: a group is the same cases in both runs."""
    columns = ["split", "by", "group", "cases", *(f"{gate}_{run}_pct" for gate in GATES for run in ("before", "after"))]
    tables = []
    for split, part in split_parts(before):
        other = after.loc[part.index]
        for by in (column for column in GROUP_COLUMNS if column in before and column in after):
            # each run's rates per group (`rates`), the groups taken from the run before in both
            runs = [rates(frame.assign(**{by: part[by]}), [by]) for frame in (part, other)]
            table = runs[0].merge(runs[1], on=[by, "cases"], suffixes=("_before", "_after"))
            table = table.rename(columns={f"{gate}_pct_{run}": f"{gate}_{run}_pct" for gate in GATES
                                          for run in ("before", "after")})
            tables.append(table.assign(split=split, by=by, group=table[by].astype(str)))
    return pd.concat(tables, ignore_index=True)[columns] if tables else pd.DataFrame(columns=columns)


def compare_runs(before: pd.DataFrame, after: pd.DataFrame, names: tuple[str, str] = ("before", "after")
                 ) -> Comparison:
    """Two runs' cases (`read_cases`) compared per split (in the order of `before`), and over them all (`POOLED`)
    where they hold more than one: the cases are drawn independently, so their gains and losses add up; DataError
    (naming the run by `names`) unless they are the same cases."""
    check_same_cases(before, after, names)
    after = after.loc[before.index]
    gates, errors = [], []
    for split, part in split_parts(before):
        other = after.loc[part.index]
        gates += [gate_change(split, gate, part, other) for gate in GATES]
        errors += [error_change(split, column, part, other) for column in ERROR_COLUMNS]
    return Comparison(tuple(gates), tuple(errors), changed_cases(before, after), group_rates(before, after))
