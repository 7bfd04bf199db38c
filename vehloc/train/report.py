"""Writing the evaluation tables: CSV files, one Markdown report (Table 1 first) and a confusion-matrix PNG."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from vehloc.atomic import atomic_dir
from vehloc.tables import markdown_table
from vehloc.train.table1 import DIMS, EvalTables


def _paper_table1(table1: pd.DataFrame) -> pd.DataFrame:
    """Table 1 in the paper's layout: ranks of the first images, real L/W/H, average % errors per rule."""
    rank_cols = [c for c in table1.columns if c.startswith("r") and c[1:].isdigit()]
    out = table1[["#", "model"] + rank_cols].rename(columns={"model": "Vehicle model"})
    out = out.rename(columns={c: c[1:] for c in rank_cols})
    out["all ranks"] = table1["ranks"]
    for dim in DIMS:
        out[f"{dim} mm"] = table1[f"{dim}_mm"].map("{:.0f}".format)
    for rule, tag in (("top1", "top-1"), ("expected", "exp.")):
        for dim in DIMS:
            out[f"{dim} err ({tag})"] = table1[f"{dim}_err_pct_{rule}"].map("{:.2f}%".format)
    return out


def write_confusion_png(confusion: np.ndarray, names: Sequence[str], path: Path) -> Path:
    """Row-normalised confusion matrix (true rows, predicted columns), labelled when classes are few."""
    rows = confusion.sum(axis=1, keepdims=True)
    share = np.divide(confusion, rows, out=np.zeros(confusion.shape), where=rows > 0)
    n = len(names)
    size_in = min(24.0, max(5.0, 0.45 * n + 2.0))
    fig = Figure(figsize=(size_in, size_in))
    ax = fig.subplots()
    image = ax.imshow(share, cmap="Blues", vmin=0.0, vmax=1.0)
    fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04, label="share of the true model's images")
    if n <= 60:
        ax.set_xticks(range(n), names, rotation=90, fontsize=7)
        ax.set_yticks(range(n), names, fontsize=7)
        if n <= 30:
            for (i, j), count in np.ndenumerate(confusion):
                if count:
                    ax.text(j, i, str(count), ha="center", va="center", fontsize=6,
                            color="white" if share[i, j] > 0.5 else "black")
    ax.set_xlabel("predicted model")
    ax.set_ylabel("true model")
    ax.set_title("Confusion matrix (test split)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return path


def write_report(tables: EvalTables, names: Sequence[str], out_dir: Path, title: str = "Evaluation",
                 run_line: str = "", warning: str = "") -> list[Path]:
    """Write every table as CSV, `report.md` (`warning`, when given, as its first line; Table 1, accuracy,
    dimension errors, confused pairs; `run_line`, e.g. the precision and device, under the summary) and `confusion_matrix.png` into `out_dir`; return the
    written paths. The folder is built beside `out_dir` and takes its place whole when every file is written,
    so an interrupt or a failure leaves earlier tables there as they were, never a mix."""
    with atomic_dir(out_dir) as staging:
        names_written = _write_report_files(tables, names, staging, title, run_line, warning)
    return [out_dir / name for name in names_written]


def _write_report_files(tables: EvalTables, names: Sequence[str], out_dir: Path, title: str, run_line: str,
                        warning: str) -> list[str]:
    written = []
    for name, frame in (
        ("table1", tables.table1),
        ("accuracy", tables.accuracy),
        ("dimension_errors", tables.dimension_summary),
        ("confused_pairs", tables.confused_pairs),
        ("predictions", tables.per_image),
    ):
        path = out_dir / f"{name}.csv"
        frame.to_csv(path, index=False, float_format="%.4f")
        written.append(path)
    accuracy = tables.accuracy.set_index("metric")["value"]
    sections = [warning] if warning else []
    sections += [
        f"# {title}",
        f"{int(accuracy['images'])} test images of {int(accuracy['classes'])} models: "
        f"top-1 {accuracy['top1_pct']:.2f} %, top-5 {accuracy['top5_pct']:.2f} %, "
        f"mean per-model top-1 {accuracy['per_class_top1_pct']:.2f} %." + (f" {run_line}" if run_line else ""),
        "## Table 1: rank of the true model and dimension errors",
        "Columns 1..N: rank (1-5, or – beyond 5) of the true model for the first test images of each model; "
        "*all ranks* counts every test image. Errors: average L/W/H error of the dimensions used, for the "
        "paper's rule (top-1 model) and the expected dimensions (probability-weighted over the top-k models).",
        markdown_table(_paper_table1(tables.table1)),
        "## Dimension errors over all test images",
        markdown_table(tables.dimension_summary),
        "## Most-confused model pairs (predicted minus true dimensions)",
        markdown_table(tables.confused_pairs) if len(tables.confused_pairs) else "No confusions.",
        "![confusion matrix](confusion_matrix.png)",
    ]
    report = out_dir / "report.md"
    report.write_text("\n\n".join(sections) + "\n", encoding="utf-8")
    written.append(report)
    written.append(write_confusion_png(tables.confusion, names, out_dir / "confusion_matrix.png"))
    return [path.name for path in written]
