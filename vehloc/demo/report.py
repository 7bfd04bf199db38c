"""The demo's report: `report.md` (Table 1, Table 2, the step times, the figures linked) and `summary.png`, the
one page a person looks at (accuracy per model, both methods' errors per Table 2 case, the bird's-eye views)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from vehloc.atomic import atomic_path, write_text  # noqa: E402
from vehloc.geometry.pipeline.drawing import METHOD_STYLES  # noqa: E402
from vehloc.geometry.pipeline.table2 import PAPER_HEADING_DEG, PAPER_POSITION_PCT  # noqa: E402
from vehloc.tables import markdown_table  # noqa: E402


def _section(markdown: str, heading: str) -> str:
    """The text of `markdown` from the line `heading` to the next heading of the same level."""
    lines = markdown.splitlines()
    start = lines.index(heading)
    level = heading.split(" ")[0]
    end = next((i for i in range(start + 1, len(lines)) if lines[i].split(" ")[0] == level), len(lines))
    return "\n".join(lines[start + 1:end]).strip()


def _table1_lines(table1_dir: Path) -> list[str]:
    text = (table1_dir / "report.md").read_text(encoding="utf-8")
    first = next(line for line in text.splitlines()[1:] if line.strip())
    return [first, "", _section(text, "## Table 1: rank of the true model and dimension errors"), "",
            "### Dimension errors over all test images", "", _section(text, "## Dimension errors over all test images")]


def write_summary_png(path: Path, table1: pd.DataFrame, table2: pd.DataFrame, birds_eye: list[Path]) -> Path:
    """Top-1 per model, position and heading errors of both methods per Table 2 case (the paper's limits
    dashed, misclassified cases hatched), and up to four bird's-eye views."""
    figure = plt.figure(figsize=(15, 10), constrained_layout=True)
    grid = figure.add_gridspec(2, 4)
    accuracy = figure.add_subplot(grid[0, :2])
    accuracy.barh(table1["model"], table1["top1_pct"], color="tab:gray")
    accuracy.invert_yaxis()
    accuracy.set_xlim(0, 100)
    accuracy.set_xlabel("top-1 on the test split (%)")
    accuracy.set_title("Table 1: classification per model")
    localized = table2[table2["status"] == "localized"] if len(table2) else table2
    scenes = list(dict.fromkeys(table2["scene"])) if len(table2) else []
    for column, (key, limit, label) in enumerate((("position_err_pct", PAPER_POSITION_PCT, "position error (% of diagonal)"),
                                                    ("heading_err_deg", PAPER_HEADING_DEG, "|heading error| (deg)"))):
        axes = figure.add_subplot(grid[0, 2 + column])
        y = np.arange(len(scenes))
        for offset, method in ((-0.2, "paper"), (0.2, "fit")):
            rows = localized[localized["method"] == method].set_index("scene") if len(localized) else pd.DataFrame()
            values = [abs(float(rows.loc[s, key])) if s in rows.index else np.nan for s in scenes]
            wrong = [s in rows.index and not bool(rows.loc[s, "correct"]) for s in scenes]
            axes.barh(y + offset, values, height=0.4, color=METHOD_STYLES[method][0], label=METHOD_STYLES[method][2],
                      hatch=[("//" if w else "") for w in wrong])
        axes.axvline(limit, color="k", linestyle="--", linewidth=1, label="paper's worst")
        axes.set_yticks(y, [s.replace("table2_", "") for s in scenes] if column == 0 else [""] * len(scenes))
        axes.invert_yaxis()
        axes.set_xlabel(label)
        axes.set_title("Table 2: " + label.split(" (")[0], fontsize=10)
        if column == 1:
            handles, labels = axes.get_legend_handles_labels()
            misclassified = Patch(facecolor="white", edgecolor="k", hatch="//")
            axes.legend([*handles, misclassified], [*labels, "misclassified"], loc="lower right")
    for index, png in enumerate(birds_eye[:4]):
        axes = figure.add_subplot(grid[1, index])
        axes.imshow(plt.imread(png))
        axes.set_title(png.parent.parent.name.replace("table2_", ""))
        axes.axis("off")
    with atomic_path(path, ".png") as temporary:
        figure.savefig(temporary, dpi=80)
    plt.close(figure)
    return path


def write_report(run_dir: Path, table1_dir: Path, table2: pd.DataFrame, table2_md: Path, step_seconds: dict[str, float],
                 header: str) -> list[Path]:
    """`report.md` and `summary.png` in `run_dir`."""
    table1 = pd.read_csv(table1_dir / "table1.csv")
    cases = sorted(run_dir.glob("table2/*/localize/birds_eye_*.png"))
    summary_png = write_summary_png(run_dir / "summary.png", table1, table2, cases)
    times = pd.DataFrame([{"step": k, "seconds": v} for k, v in step_seconds.items()])
    table2_text = table2_md.read_text(encoding="utf-8")
    lines = [
        "# vehloc demo report", "", header, "", f"![summary]({summary_png.name})", "",
        "## Table 1: classification and dimension errors", "", *_table1_lines(table1_dir), "",
        f"Confusion matrix: [{(table1_dir / 'confusion_matrix.png').relative_to(run_dir)}]"
        f"({(table1_dir / 'confusion_matrix.png').relative_to(run_dir)})", "",
        "## Table 2: localization on the road plane", "",
        "\n".join(table2_text.splitlines()[1:]).strip().replace("## ", "### "), "",
        "Bird's-eye views (true footprint and tyres, both estimates): "
        + ", ".join(f"[{p.parent.parent.name}]({p.relative_to(run_dir)})" for p in cases), "",
        "## Steps", "", markdown_table(times, "{:.1f}") if len(times) else "", "",
    ]
    return [write_text(run_dir / "report.md", "\n".join(lines)), summary_png]
