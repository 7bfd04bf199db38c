"""A speed score as files: `matches.csv` (one row per true car), `speed_eval.csv` and `speed_eval.md` (the
summary, the field's published figures beside it) and `speed_eval.png` (the error histogram and the measured against
the true speeds)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vehloc.atomic import write_bytes, write_text
from vehloc.geometry.pipeline.speed_eval import SpeedScore

if TYPE_CHECKING:
    import pandas as pd

PUBLISHED = (
    ("Kocur and Ftáčnik 2020 (BrnoCompSpeed split C)", 0.75, 0.58),
    ("Sochor et al. 2017, fully automatic (split C)", 1.10, 0.97),
    ("Sochor et al. 2017, manual calibration (split C)", 1.35, None),
)
"""The field's published mean / median speed errors (km/h) on the real benchmark."""


def matches_table(score: SpeedScore) -> pd.DataFrame:
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    return pd.DataFrame([{"truth_id": m.truth_id, "lane": m.lane, "valid": m.valid, "last_time_s": m.last_time_s,
                          "true_speed_kmh": m.true_speed_kmh, "car_id": m.car_id, "speed_kmh": m.speed_kmh,
                          "error_kmh": m.error_kmh} for m in score.matches])


def summary_markdown(summary: dict[str, float], title: str) -> str:
    fmt = lambda v: "-" if v is None or not np.isfinite(v) else f"{v:.2f}"  # noqa: E731
    lines = [f"# {title}", "",
             "| | mean | median | 95th pct | worst |", "|---|---|---|---|---|",
             "| speed error (km/h) | " + " | ".join(fmt(summary[f"{s}_error_kmh"]) for s in ("mean", "median", "p95", "worst")) + " |",
             "| speed error (%) | " + " | ".join(fmt(summary[f"{s}_error_percent"]) for s in ("mean", "median", "p95", "worst")) + " |",
             "", f"Recall {summary['recall'] * 100:.1f} % ({summary['measured']:.0f} of {summary['true_cars']:.0f} valid true "
             f"cars measured), precision {summary['precision'] * 100:.1f} % ({summary['false_positives']:.0f} false "
             f"positives); distance error towards the first vanishing point {fmt(summary['mean_distance_error_m'])} m "
             f"({fmt(summary['mean_distance_error_percent'])} %) on average.", "",
             "The field's published figures on the real benchmark, for comparison:", "",
             "| system | mean (km/h) | median (km/h) |", "|---|---|---|"]
    lines += [f"| {name} | {mean:.2f} | {fmt(median)} |" for name, mean, median in PUBLISHED]
    return "\n".join(lines) + "\n"


def score_plot(score: SpeedScore, title: str) -> bytes:
    from matplotlib.figure import Figure

    matched = [m for m in score.matches if m.speed_kmh is not None and m.valid]
    errors = np.array([m.error_kmh for m in matched])
    figure = Figure(figsize=(10, 4), dpi=110)
    left, right = figure.subplots(1, 2)
    if len(errors):
        limit = max(1.0, float(np.max(np.abs(errors))))
        left.hist(errors, bins=np.linspace(-limit, limit, 31), color="#3870a8", edgecolor="white")
        truths = np.array([m.true_speed_kmh for m in matched])
        right.scatter(truths, truths + errors, s=12, color="#3870a8")
        span = [truths.min() - 5, truths.max() + 5]
        right.plot(span, span, color="grey", linestyle="--", linewidth=1)
    left.set_xlabel("measured - true speed (km/h)")
    left.set_ylabel("vehicles")
    left.set_title("speed error")
    right.set_xlabel("true speed (km/h)")
    right.set_ylabel("measured speed (km/h)")
    right.set_title("measured against true")
    figure.suptitle(title)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return buffer.getvalue()


def write_score(score: SpeedScore, out_dir: Path, title: str) -> dict[str, float]:
    """Write the score's files into `out_dir`; its summary."""
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    summary = score.summary()
    write_text(out_dir / "matches.csv", matches_table(score).to_csv(index=False, float_format="%.3f"))
    write_text(out_dir / "speed_eval.csv", pd.DataFrame([summary]).to_csv(index=False, float_format="%.4f"))
    write_text(out_dir / "speed_eval.md", summary_markdown(summary, title))
    write_bytes(out_dir / "speed_eval.png", score_plot(score, title))
    return summary
