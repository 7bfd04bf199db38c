"""The benchmark's tables and figures: the gate's rates per split, the rates per group (model, colour, heading
band, view, distance band, the road's resolution at the car, camera), error against the view angle and distance,
and a contact sheet of the cases that fall short of a bar."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from vehloc.atomic import atomic_path, write_image, write_text
from vehloc.geometry.pipeline.drawing import METHOD_STYLES
from vehloc.tables import markdown_table

GATES = {
    "localized": "localized (either method)",
    "fit_within": "model fit within 1 % and 1 deg (correct model)",
    "key_points_found": "paper's key points found (plate or two tyres visible)",
    "paper_within": "paper's method within 2.85 % and 2.5 deg (plate or two tyres visible)",
}
BARS = {"localized": 98.0, "fit_within": 95.0, "key_points_found": 90.0, "paper_within": 90.0}
"""The issue's bars, in per cent of each gate's cases."""
VIEWS = ((22.5, "front"), (67.5, "front quarter"), (112.5, "side"), (157.5, "rear quarter"), (180.1, "rear"))
DISTANCE_BANDS_M = (5, 10, 20, 30, 40)
RESOLUTION_BANDS_MM_PER_PX = (0, 25, 50, 100, 200, 10_000)
"""Bands of the road's resolution at the car (mm one pixel spans there, in its worst direction): 1 % of a car's
diagonal is about 50 mm, so beyond 50 mm/px the fit's bar is finer than a pixel."""
INTERVAL_Z = 1.96
"""The gates' rates carry their 95 % interval (normal quantile 1.96): a rate over 200 cases is known to a few points."""


def wilson_interval_pct(successes: int, cases: int, z: float = INTERVAL_Z) -> tuple[float, float]:
    """The Wilson score interval (per cent) of a rate of `successes` in `cases`: where the rate over many more cases
    of the same draw would lie, at the confidence of the normal quantile `z`; (0, 100) for no cases."""
    if cases == 0:
        return 0.0, 100.0
    rate = successes / cases
    centre = (rate + z * z / (2 * cases)) / (1 + z * z / cases)
    half = z / (1 + z * z / cases) * np.sqrt(rate * (1 - rate) / cases + z * z / (4 * cases * cases))
    return 100.0 * max(float(centre - half), 0.0), 100.0 * min(float(centre + half), 1.0)


def view_angle_deg(row: pd.Series) -> float:
    """The angle (deg, 0-180) between the car's front and the direction from it to the camera's foot."""
    sight = np.degrees(np.arctan2(row["camera_y_mm"] - row["y_mm"], row["camera_x_mm"] - row["x_mm"]))
    return abs((row["heading_deg"] - sight + 180.0) % 360.0 - 180.0)


def view_of(row: pd.Series) -> str:
    """How the car shows itself, by `view_angle_deg`: `front` 0-22.5 deg, `front quarter`, `side`,
    `rear quarter`, `rear` 157.5-180 deg; `unknown` for a row without the pose or the camera."""
    angle = view_angle_deg(row)
    return next((name for limit, name in VIEWS if angle < limit), "unknown")


def flag(frame: pd.DataFrame, column: str) -> np.ndarray:
    """A yes/no column as 1.0 and 0.0, 0.0 where it is missing (a method that gave no estimate)."""
    if column not in frame:
        return np.zeros(len(frame))
    return frame[column].eq(True).to_numpy(dtype=float)


def with_groups(cases: pd.DataFrame) -> pd.DataFrame:
    """The cases with their group columns and per-gate flags (NaN where a case is not in a gate's cases)."""
    frame = cases.copy()
    frame["view"] = frame.apply(view_of, axis=1)
    frame["heading_band"] = (frame["heading_deg"] // 45 * 45).astype(int).map(lambda d: f"{d}-{d + 45}")
    edges = np.array(DISTANCE_BANDS_M) * 1000.0
    labels = [f"{a}-{b} m" for a, b in zip(DISTANCE_BANDS_M, DISTANCE_BANDS_M[1:])]
    frame["distance_band"] = pd.cut(frame["distance_mm"], edges, labels=labels, include_lowest=True)
    if "road_mm_per_px" in frame:
        bands = RESOLUTION_BANDS_MM_PER_PX
        names = [f"{a}-{b} mm/px" if b < bands[-1] else f"> {a} mm/px" for a, b in zip(bands, bands[1:])]
        frame["resolution_band"] = pd.cut(frame["road_mm_per_px"], bands, labels=names)
    frame["localized"] = frame["localized"].astype(float)
    correct = frame["correct"].astype(bool) & frame["localized"].astype(bool)
    frame["fit_within"] = np.where(correct, flag(frame, "fit_within"), np.nan)
    visible = frame["key_points_visible"].astype(bool)
    found = frame["key_point"].fillna("").astype(str).isin(["plate", "wheels", "wheel"])
    frame["key_points_found"] = np.where(visible, found.astype(float), np.nan)
    frame["paper_within"] = np.where(visible, flag(frame, "paper_within"), np.nan)
    return frame


def rates(frame: pd.DataFrame, by: Sequence[str]) -> pd.DataFrame:
    """Per group: the number of cases and each gate's rate in per cent (over the gate's own cases), with its
    count of cases in brackets in `<gate>_cases`."""
    rows = []
    for key, group in frame.groupby(list(by), sort=True, observed=True):
        key = key if isinstance(key, tuple) else (key,)
        row = dict(zip(by, key)) | {"cases": len(group)}
        for gate in GATES:
            values = group[gate].dropna()
            row[f"{gate}_pct"] = 100.0 * values.mean() if len(values) else np.nan
            row[f"{gate}_cases"] = len(values)
        rows.append(row)
    return pd.DataFrame(rows)


def gate_lines(frame: pd.DataFrame) -> list[str]:
    """Per split, each gate's rate with its 95 % interval against its bar."""
    lines = ["| split | gate | cases | rate | 95 % interval | bar | met |", "|---|---|---|---|---|---|---|"]
    for split, group in frame.groupby("split", sort=False):
        for gate, title in GATES.items():
            values = group[gate].dropna()
            rate = 100.0 * values.mean() if len(values) else float("nan")
            low, high = wilson_interval_pct(int(values.sum()), len(values))
            lines.append(f"| {split} | {title} | {len(values)} | {rate:.1f} % | {low:.1f}-{high:.1f} % | "
                         f"{BARS[gate]:.0f} % | {'yes' if rate >= BARS[gate] else 'no'} |")
    return lines


def error_figure(frame: pd.DataFrame, path: Path) -> Path:
    """Each method's position % and heading error against the case's view angle and distance."""
    fig = Figure(figsize=(11, 7))
    axes = fig.subplots(2, 2)
    angle = frame.apply(view_angle_deg, axis=1)
    for method in ("paper", "fit"):
        colour, marker, name = METHOD_STYLES[method]
        column = f"{method}_position_pct"
        if column not in frame:
            continue
        for col, (x, label) in enumerate(((angle, "angle between the car's front and the camera (deg)"),
                                          (frame["distance_mm"] / 1000.0, "distance from the camera's foot (m)"))):
            axes[0, col].scatter(x, frame[column].clip(1e-3), s=12, c=colour, marker=marker, label=name)
            axes[1, col].scatter(x, frame[f"{method}_heading_deg"].clip(1e-3), s=12, c=colour, marker=marker, label=name)
            axes[1, col].set_xlabel(label)
    for row, (bar_fit, bar_paper, name) in enumerate(((1.0, 2.85, "position error (% of the diagonal)"),
                                                       (1.0, 2.5, "heading error (deg)"))):
        for ax in axes[row]:
            ax.set_yscale("log")
            ax.axhline(bar_fit, color=METHOD_STYLES["fit"][0], linewidth=0.8, linestyle="--", label="model fit's bar")
            ax.axhline(bar_paper, color=METHOD_STYLES["paper"][0], linewidth=0.8, linestyle="--", label="paper's figures")
            ax.set_ylabel(name)
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{len(frame)} cases: errors of the localized ones (dashed: the bars)")
    fig.tight_layout()
    with atomic_path(path) as temporary:
        fig.savefig(temporary, format="png", dpi=90)
    return path


def contact_sheet(cells: Sequence[np.ndarray], path: Path, columns: int = 6) -> Path | None:
    """The pictures of the cases that fall short, in rows of `columns`; None when there is none."""
    if not cells:
        return None
    height, width = cells[0].shape[:2]
    rows = -(-len(cells) // columns)
    sheet = np.full((rows * height, columns * width, 3), 255, np.uint8)
    for index, cell in enumerate(cells):
        r, c = divmod(index, columns)
        sheet[r * height:(r + 1) * height, c * width:(c + 1) * width] = cell
    return write_image(path, sheet)


def why_not_localized(grouped: pd.DataFrame) -> str:
    """The cases not localized by their reason code, each with one case's sentence (a case whose run raised: `error`)."""
    failed = grouped[~grouped["localized"].astype(bool)]
    if not len(failed):
        return "Every case was localized."
    codes = failed["reason_code"].fillna("").astype(str) if "reason_code" in failed else pd.Series("", failed.index)
    table = (failed.assign(reason_code=codes.where(codes != "", "error"))
             .groupby("reason_code").agg(cases=("reason", "size"), example=("reason", "first"))
             .sort_values("cases", ascending=False).reset_index())
    return markdown_table(table, "{:.0f}")


def write_report(frame: pd.DataFrame, out_dir: Path, title: str, cells: Sequence[np.ndarray]) -> list[Path]:
    """`cases.csv`, `groups.csv`, `report.md`, `errors.png` and `failures.png` (when a case falls short)."""
    grouped = with_groups(frame)
    group_tables = {by: rates(grouped, ["split", by]) for by in
                    ("model", "colour_group", "view", "heading_band", "distance_band", "resolution_band", "camera_name")
                    if by in grouped}
    groups = pd.concat([t.rename(columns={by: "group"}).assign(by=by) for by, t in group_tables.items()],
                       ignore_index=True)
    written = [write_text(out_dir / "cases.csv", grouped.to_csv(index=False, float_format="%.3f")),
               write_text(out_dir / "groups.csv", groups.to_csv(index=False, float_format="%.1f"))]
    shown = ["cases"] + [f"{gate}_pct" for gate in GATES]
    lines = [f"# {title}", "", "Each gate's rate is over its own cases: the model fit's over the correctly classified "
             "localized cases, the paper's key points over the cases whose truth shows a plate or two tyres of a side.",
             "", "## Gates", "", *gate_lines(grouped), ""]
    for by, table in group_tables.items():
        lines += [f"## By {by.replace('_', ' ')}", "", markdown_table(table[["split", by] + shown], "{:.1f}"), ""]
    lines += ["## Why not localized", "", why_not_localized(grouped), ""]
    written.append(write_text(out_dir / "report.md", "\n".join(lines)))
    written.append(error_figure(grouped, out_dir / "errors.png"))
    sheet = contact_sheet(cells, out_dir / "failures.png")
    return written + ([sheet] if sheet else [])
