"""Two benchmark runs compared (`vehloc.benchmark.paired`), written for a person: `gates.csv`, `errors.csv` and
`changed_cases.csv`, `compare.md` (the gates with their gains, losses and p-values, the error columns, the
changed cases) and `compare.png` (each case's error before against after, per method)."""

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
BARS_PCT = {"fit": 1.0, "paper": 2.85}
"""Each method's position bar (per cent of the diagonal), drawn on the figure."""


def seeds_text(seeds: tuple[int, ...]) -> str:
    shown = ", ".join(str(s) for s in seeds[:SEEDS_SHOWN])
    return shown + (f" (+{len(seeds) - SEEDS_SHOWN})" if len(seeds) > SEEDS_SHOWN else "")


def gates_table(comparison: Comparison) -> pd.DataFrame:
    return pd.DataFrame([{"split": g.split, "gate": GATES[g.gate], "cases in both": g.cases,
                          "before %": g.before_pct, "after %": g.after_pct, "bar %": BARS[g.gate],
                          "gained": len(g.gained), "lost": len(g.lost), "McNemar p": g.p_value,
                          "verdict": "changed" if g.p_value < EVIDENCE_P else "no evidence of a change",
                          "seeds gained": seeds_text(g.gained), "seeds lost": seeds_text(g.lost)}
                         for g in comparison.gates])


def errors_table(comparison: Comparison) -> pd.DataFrame:
    return pd.DataFrame([{"split": e.split, "error": e.column, "cases in both": e.cases, "better": e.better,
                          "worse": e.worse, "median change of the moved": e.median_change, "sign test p": e.p_value}
                         for e in comparison.errors])


def paired_figure(changed: pd.DataFrame, path: Path) -> Path:
    """Per method, each case whose estimate by it moved (`MOVE_TOLERANCE`) or whose gate changed: its position
    error after against before (log scales), the gained ones green, the lost red, the diagonal and the bar dashed."""
    fig = Figure(figsize=(10, 4.8))
    for ax, method in zip(fig.subplots(1, 2), ("fit", "paper")):
        before = changed[f"{method}_position_pct_before"].to_numpy(dtype=float)
        after = changed[f"{method}_position_pct_after"].to_numpy(dtype=float)
        gate = changed[f"{method}_within"].to_numpy(dtype=str)
        heading = (changed[f"{method}_heading_deg_after"] - changed[f"{method}_heading_deg_before"]).abs()
        moved = (np.abs(after - before) > MOVE_TOLERANCE) | (heading.to_numpy(dtype=float) > MOVE_TOLERANCE)
        both = ~np.isnan(before) & ~np.isnan(after) & (moved | (gate != ""))
        for mark, colour, label in (("", "0.55", "gate unchanged"), ("gained", "tab:green", "gained the gate"),
                                    ("lost", "tab:red", "lost the gate")):
            chosen = both & (gate == mark)
            ax.scatter(before[chosen].clip(1e-3), after[chosen].clip(1e-3), s=14, c=colour,
                       label=f"{label} ({int(chosen.sum())})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        low, high = 1e-3, max(10.0, float(np.nanmax(np.r_[before[both], after[both], 1.0])) * 1.5)
        ax.plot([low, high], [low, high], color="0.3", linewidth=0.8)
        ax.axhline(BARS_PCT[method], color=METHOD_STYLES[method][0], linestyle="--", linewidth=0.8)
        ax.axvline(BARS_PCT[method], color=METHOD_STYLES[method][0], linestyle="--", linewidth=0.8)
        ax.set_xlim(low, high)
        ax.set_ylim(low, high)
        ax.set_xlabel("before: position error (% of the diagonal)")
        ax.set_ylabel("after")
        ax.set_title(f"{METHOD_STYLES[method][2]}: {int(both.sum())} cases moved")
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
               write_text(out_dir / "changed_cases.csv", comparison.changed.to_csv(index=False, float_format="%.3f"))]
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
             f"## The {len(comparison.changed)} changed cases", "",
             markdown_table(comparison.changed, "{:.3f}") if len(comparison.changed) else "No case changed.", "",
             "![each changed case's error before and after](compare.png)", ""]
    written.append(write_text(out_dir / "compare.md", "\n".join(lines)))
    written.append(paired_figure(comparison.changed, out_dir / "compare.png"))
    return written
