"""Two benchmark runs compared (`vehloc.benchmark.paired`), written for a person: `gates.csv`, `errors.csv`,
`changed_cases.csv` and `groups.csv`, `compare.md` (the gates with their gains, losses and p-values, the error
columns, each gate per group before and after, the changed cases) and `compare.png` (each case's error before
against after, per method)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from vehloc.atomic import atomic_path, write_text
from vehloc.benchmark.paired import MOVE_TOLERANCE, Comparison
from vehloc.benchmark.report import BARS, GATES
from vehloc.geometry.pipeline.drawing import METHOD_STYLES
from vehloc.tables import markdown_table

EVIDENCE_P = 0.05
"""A gate's change is called a change where the exact McNemar p-value is below this."""
SEEDS_SHOWN = 12
"""Gained and lost seeds listed per gate in the Markdown (all are in the CSV)."""
ERRORS = {"position_pct": "position error (% of the diagonal)", "heading_deg": "heading error (deg)"}
METHOD_BARS = {"fit": (1.0, 1.0), "paper": (2.85, 2.5)}
"""Each method's bars on its errors (`ERRORS`' order), drawn on the figure."""
GATE_SHORT = {"localized": "localized %", "fit_within": "fit within %", "key_points_found": "key points found %",
              "paper_within": "paper's method within %"}
"""The gates' names as the per-group tables' columns."""


def seeds_text(seeds: tuple[int, ...]) -> str:
    """The first `SEEDS_SHOWN` seeds, and how many more."""
    shown = ", ".join(str(s) for s in seeds[:SEEDS_SHOWN])
    return shown + (f" (+{len(seeds) - SEEDS_SHOWN})" if len(seeds) > SEEDS_SHOWN else "")


def gates_table(comparison: Comparison) -> pd.DataFrame:
    """One row per split and gate, with the verdict at `EVIDENCE_P`."""
    return pd.DataFrame([{"split": g.split, "gate": GATES[g.gate], "cases in both": g.cases,
                          "before %": g.before_pct, "after %": g.after_pct, "bar %": BARS[g.gate],
                          "gained": len(g.gained), "lost": len(g.lost), "McNemar p": g.p_value,
                          "verdict": "changed" if g.p_value < EVIDENCE_P else "no evidence of a change",
                          "seeds gained": seeds_text(g.gained), "seeds lost": seeds_text(g.lost)}
                         for g in comparison.gates])


def errors_table(comparison: Comparison) -> pd.DataFrame:
    """One row per split and error column."""
    return pd.DataFrame([{"split": e.split, "error": e.column, "cases in both": e.cases, "better": e.better,
                          "worse": e.worse, "median change of the moved": e.median_change, "sign test p": e.p_value}
                         for e in comparison.errors])


def groups_table(comparison: Comparison, by: str) -> pd.DataFrame:
    """Per split and group of the column `by`: its cases and each gate's rate as `before -> after` (per cent;
    `-` where the run has no case of the group in the gate)."""
    groups = comparison.groups[comparison.groups["by"] == by]

    def pct(value: float) -> str:
        return "-" if np.isnan(value) else f"{value:.1f}"

    return pd.DataFrame([{"split": row["split"], by.replace("_", " "): row["group"], "cases": row["cases"]}
                         | {GATE_SHORT[gate]: f"{pct(row[f'{gate}_before_pct'])} -> {pct(row[f'{gate}_after_pct'])}"
                            for gate in GATES}
                         for _, row in groups.iterrows()])


def paired_figure(changed: pd.DataFrame, path: Path) -> Path:
    """Per method (columns) and error (rows: position, heading), each case whose estimate by that method moved
    (`MOVE_TOLERANCE`) or whose gate changed: its error after against before (log scales), the gained ones green,
    the lost red, the diagonal and the bar dashed."""
    fig = Figure(figsize=(10, 9))
    axes = fig.subplots(2, 2)
    for col, method in enumerate(("fit", "paper")):
        values = {error: (changed[f"{method}_{error}_before"].to_numpy(dtype=float),
                          changed[f"{method}_{error}_after"].to_numpy(dtype=float)) for error in ERRORS}
        gate = changed[f"{method}_within"].to_numpy(dtype=str)
        moved = np.any([np.abs(after - before) > MOVE_TOLERANCE for before, after in values.values()], axis=0)
        both = np.all([~np.isnan(before) & ~np.isnan(after) for before, after in values.values()], axis=0)
        shown = both & (moved | (gate != ""))
        for row, (error, (before, after)) in enumerate(values.items()):
            ax = axes[row, col]
            for mark, colour, label in (("", "0.55", "gate unchanged"), ("gained", "tab:green", "gained the gate"),
                                        ("lost", "tab:red", "lost the gate")):
                chosen = shown & (gate == mark)
                ax.scatter(before[chosen].clip(1e-3), after[chosen].clip(1e-3), s=14, c=colour,
                           label=f"{label} ({int(chosen.sum())})")
            low, high = 1e-3, max(10.0, float(np.nanmax(np.r_[before[shown], after[shown], 1.0])) * 1.5)
            ax.plot([low, high], [low, high], color="0.3", linewidth=0.8)
            bar = METHOD_BARS[method][row]
            ax.axhline(bar, color=METHOD_STYLES[method][0], linestyle="--", linewidth=0.8)
            ax.axvline(bar, color=METHOD_STYLES[method][0], linestyle="--", linewidth=0.8)
            ax.set(xscale="log", yscale="log", xlim=(low, high), ylim=(low, high), ylabel="after",
                   xlabel=f"before: {ERRORS[error]}")
            ax.set_title(f"{METHOD_STYLES[method][2]}: {int(shown.sum())} cases moved", fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    with atomic_path(path) as temporary:
        fig.savefig(temporary, format="png", dpi=90)
    return path


def write_comparison(comparison: Comparison, out_dir: Path, names: tuple[str, str]) -> list[Path]:
    """The comparison's CSV files, Markdown and figure in `out_dir`; each written whole or not at all."""
    gates, errors = gates_table(comparison), errors_table(comparison)
    written = [write_text(out_dir / "gates.csv", gates.to_csv(index=False, float_format="%.4g")),
               write_text(out_dir / "errors.csv", errors.to_csv(index=False, float_format="%.4g")),
               write_text(out_dir / "changed_cases.csv", comparison.changed.to_csv(index=False, float_format="%.3f")),
               write_text(out_dir / "groups.csv", comparison.groups.to_csv(index=False, float_format="%.2f"))]
    group_lines = []
    for by in comparison.groups["by"].unique():
        group_lines += [f"### By {by.replace('_', ' ')}", "", markdown_table(groups_table(comparison, by)), ""]
    lines = [f"# {names[0]} against {names[1]}", "",
             "The same seeds, each drawn as the same case, run twice. A gate's rate is over each run's own cases "
             "of the gate; gained and lost are over the cases in the gate in both. Only cases that changed sides "
             "carry evidence: the McNemar p-value is the chance of a split of them at least this uneven were the "
             f"change to make no difference (below {EVIDENCE_P}: called a change).", "",
             "## Gates", "", markdown_table(gates, "{:.3g}"), "",
             "## Errors", "",
             "Over the cases with the estimate in both runs: better or worse by more than 0.01 (per cent of the "
             "diagonal or deg), the median change (after - before) of those that moved, and the sign test on better "
             "against worse.", "",
             markdown_table(errors, "{:.3g}"), "",
             "## By group", "",
             "Each gate's rate before -> after (per cent of the group's cases in the gate; all in `groups.csv`).", "",
             *(group_lines or ["The runs' cases.csv share no group column.", ""]),
             f"## The {len(comparison.changed)} changed cases", "",
             markdown_table(comparison.changed, "{:.3f}") if len(comparison.changed) else "No case changed.", "",
             "![each changed case's error before and after](compare.png)", ""]
    written.append(write_text(out_dir / "compare.md", "\n".join(lines)))
    written.append(paired_figure(comparison.changed, out_dir / "compare.png"))
    return written
