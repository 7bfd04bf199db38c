"""Localization records against a scene's ground truth: the paper's Table 2 rows (one per stopped car and
method), a summary against the paper's figures, and the files a person looks at (CSV, Markdown,
bird's-eye PNGs)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vehloc.atomic import write_text
from vehloc.data.boxes import Box
from vehloc.data.specs import display_name
from vehloc.geometry.pipeline.drawing import write_birds_eye
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.pipeline.localize import Status, VehicleRecord
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.pipeline.table2 import (
    PAPER_DIMENSION_PCT,
    PAPER_HEADING_DEG,
    PAPER_POSITION_PCT,
    combined_accuracy_pct,
    pose_error,
    true_box_from_tyres,
)
from vehloc.geometry.truth import CarTruth, SceneTruth
from vehloc.tables import markdown_table

if TYPE_CHECKING:
    import pandas as pd

MIN_MATCH_IOU = 0.5
AT_STOP_DIAGONAL_FRACTION = 0.005
"""A record made before a car's stop frame is its stop's when the car is by then within this fraction of its diagonal
of where it stops (slowing evenly, a frame or two before: the tracker calls a box still over ten frames within 2 % of
its diagonal). Its errors are taken against the stop all the same, the last of its travel included."""
METHODS = ("paper", "fit")


NOT_TRACKED_TO_STOP = NotPlaced(ReasonCode.NOT_TRACKED_TO_STOP, "no vehicle was tracked to a stop there")
"""Why a stopped car of the truth has no record: no track stopped over it (Table 2's match found none)."""

def true_box(car: CarTruth) -> VehicleBox:
    """The car's true footprint at its stop, from its four tyre positions and its specifications."""
    return true_box_from_tyres(car.tyre_contacts_mm, car.axle_middle_x_mm, car.length_mm, car.width_mm)


def at_stop(frame: int, stop_frame: int, centre_mm: tuple[float, float] | None, stop_centre_mm: tuple[float, float],
            diagonal_mm: float) -> bool:
    """Whether a car whose centre is at `centre_mm` in `frame` stands at its stop: from its stop frame on, or before
    it within `AT_STOP_DIAGONAL_FRACTION` of its diagonal of its stop."""
    if frame >= stop_frame:
        return True
    return centre_mm is not None and bool(
        np.hypot(centre_mm[0] - stop_centre_mm[0], centre_mm[1] - stop_centre_mm[1])
        <= AT_STOP_DIAGONAL_FRACTION * diagonal_mm)


def is_stop_record(record: VehicleRecord, standing: bool, truth_box: Box | None) -> bool:
    """Whether `record` is a stopped car's (Table 2's rule): made while the car stands at its stop (`at_stop`), its box
    overlapping the car's true box in that frame by at least `MIN_MATCH_IOU`."""
    return standing and truth_box is not None and record.box_px.iou(truth_box) >= MIN_MATCH_IOU


def match(car: CarTruth, records: Sequence[VehicleRecord]) -> VehicleRecord | None:
    """The record of a stopped car: the first that `is_stop_record`."""
    stop_centre_mm = (car.target_pose.x_mm, car.target_pose.y_mm)
    diagonal_mm = float(np.hypot(car.length_mm, car.width_mm))
    for record in sorted(records, key=lambda r: r.frame):
        in_truth = record.frame < len(car.boxes)
        truth_box = car.boxes[record.frame] if in_truth else None
        pose = car.poses[record.frame] if in_truth else None
        centre_mm = None if pose is None else (pose.x_mm, pose.y_mm)
        if is_stop_record(record, at_stop(record.frame, car.stop_frame or 0, centre_mm, stop_centre_mm, diagonal_mm),
                          truth_box):
            return record
    return None


def table2_rows(truth: SceneTruth, records: Sequence[VehicleRecord]) -> list[dict[str, object]]:
    """One row per stopped car and method (or one saying the car was not localized), with the paper's
    errors and percentages."""
    rows = []
    for index, car in enumerate(c for c in truth.cars if c.stops):
        record = match(car, records)
        box = true_box(car)
        base = {
            "scene": truth.name, "car": index, "true_model": display_name(car.make, car.model),
            "true_x_mm": box.centre_mm[0], "true_y_mm": box.centre_mm[1], "true_heading_deg": box.heading_deg,
        }
        if record is None or record.status != Status.LOCALIZED:
            why = NOT_TRACKED_TO_STOP if record is None else NotPlaced(record.reason_code, record.reason)
            rows.append(base | {"status": Status.NOT_LOCALIZED, "reason_code": why.code, "reason": why.message})
            continue
        base |= {"predicted_model": display_name(record.make, record.model), "correct": record.model_id == car.model_id,
                 "frame": record.frame, "status": Status.LOCALIZED, "notes": record.notes}
        for estimate in record.estimates:
            error = pose_error(estimate.box, box)
            rows.append(base | {
                "method": estimate.method, "key_point": estimate.key_point or "",
                "x_mm": estimate.box.centre_mm[0], "y_mm": estimate.box.centre_mm[1],
                "heading_deg": estimate.box.heading_deg,
                "x_err_mm": error.x_mm, "y_err_mm": error.y_mm, "position_err_mm": error.position_mm,
                "heading_err_deg": error.heading_deg, "x_err_pct": error.x_pct, "y_err_pct": error.y_pct,
                "position_err_pct": error.position_pct, "within_paper": error.within_paper(),
                "sigma_position_mm": estimate.uncertainty.position_mm,
                "sigma_heading_deg": estimate.uncertainty.heading_deg, "iou": estimate.iou,
            })
    return rows


def summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per method over the correctly classified cases: the worst and mean position % and heading error, the
    worst combined with the paper's 2.5 % dimension error, and how many cases are within the paper's
    figures."""
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    rows = []
    if "method" not in frame.columns:
        return pd.DataFrame(rows)
    for method in METHODS:
        cases = frame[(frame["method"] == method) & frame["correct"].astype(bool)]
        if cases.empty:
            continue
        worst = float(cases["position_err_pct"].max())
        rows.append({
            "method": method, "cases": len(cases),
            "max_position_pct": worst, "mean_position_pct": float(cases["position_err_pct"].mean()),
            "max_heading_deg": float(cases["heading_err_deg"].abs().max()),
            "mean_heading_deg": float(cases["heading_err_deg"].abs().mean()),
            "combined_pct": combined_accuracy_pct(worst, PAPER_DIMENSION_PCT),
            "within_paper": f"{int(cases['within_paper'].sum())}/{len(cases)}",
        })
    return pd.DataFrame(rows)


def write_table2(frame: pd.DataFrame, out_dir: Path, title: str) -> list[Path]:
    """`table2.csv`, `table2_summary.csv` and `table2.md` (the cases, the summary, the paper's figures)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    summary_frame = summary(frame)
    written = [write_text(out_dir / "table2.csv", frame.to_csv(index=False, float_format="%.3f")),
               write_text(out_dir / "table2_summary.csv", summary_frame.to_csv(index=False, float_format="%.3f"))]
    shown = ["scene", "method", "key_point", "predicted_model", "correct", "x_err_mm", "y_err_mm", "position_err_mm",
             "heading_err_deg", "x_err_pct", "y_err_pct", "position_err_pct", "sigma_position_mm", "sigma_heading_deg"]
    cases = frame[[c for c in shown if c in frame.columns]] if len(frame) else frame
    lines = [
        f"# {title}", "",
        "Errors are estimated minus true; X % of the car's length, Y % of its width, position % of its footprint "
        f"diagonal (the paper's definitions). The paper reaches position <= {PAPER_POSITION_PCT} % and heading "
        f"<= {PAPER_HEADING_DEG} deg, {combined_accuracy_pct(PAPER_POSITION_PCT):.2f} % with a "
        f"{PAPER_DIMENSION_PCT} % dimension error.", "",
        "## Summary (correctly classified cases)", "",
        markdown_table(summary_frame, "{:.2f}") if len(summary_frame) else "No correctly classified case.", "",
        "## Cases", "", markdown_table(cases, "{:.2f}") if len(cases) else "No case.", "",
    ]
    not_localized = frame[frame["status"] != Status.LOCALIZED] if "status" in frame else frame.iloc[0:0]
    if len(not_localized):
        lines += ["## Not localized", "", markdown_table(not_localized[["scene", "true_model", "reason"]]), ""]
    written.append(write_text(out_dir / "table2.md", "\n".join(lines)))
    return written


def write_case_figures(truth: SceneTruth, records: Sequence[VehicleRecord], out_dir: Path) -> list[Path]:
    """A bird's-eye PNG per stopped car: the true footprint with its tyres and the estimated ones."""
    written = []
    for index, car in enumerate(c for c in truth.cars if c.stops):
        record = match(car, records)
        boxes = {"truth": true_box(car)}
        if record is not None:
            boxes |= {e.method: e.box for e in record.estimates}
        title = f"{truth.name}, car {index}: {car.make} {car.model}"
        written.append(write_birds_eye(out_dir / f"birds_eye_{truth.name}_car{index}.png", boxes, title,
                                       np.asarray(car.tyre_contacts_mm)))
    return written
