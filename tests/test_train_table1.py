"""Table 1 and the evaluation tables from hand-made probabilities; the report files."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from vehloc.train.report import write_report
from vehloc.train.table1 import ClassTable, evaluate_predictions, rank_histogram, true_ranks

CLASSES = ClassTable(
    model_ids=[11, 12, 25, 30, 31, 32, 33],
    names=["Alpha", "Beta", "Gamma", "D", "E", "F", "G"],
    dims_mm=np.array([
        [4500, 1800, 1450], [4600, 1850, 1470], [4000, 1700, 1600],
        [4100, 1700, 1500], [4200, 1700, 1500], [4300, 1700, 1500], [4400, 1700, 1500],
    ], dtype=float),
)


def _probs(rows: list[list[float]]) -> np.ndarray:
    probs = np.asarray(rows, dtype=float)
    return probs / probs.sum(axis=1, keepdims=True)


def test_ranks_count_classes_with_higher_probability():
    probs = _probs([[0.5, 0.3, 0.2, 0, 0, 0, 0], [0.1, 0.6, 0.3, 0, 0, 0, 0], [0.01, 0.02, 0.03, 0.2, 0.2, 0.3, 0.24]])
    assert true_ranks(probs, np.array([0, 2, 0])).tolist() == [1, 2, 7]
    # equal probabilities rank in class order, as argmax takes the first: top-1 is argmax, never optimistic
    tied = np.array([[0.4, 0.4, 0.2], [0.4, 0.4, 0.2]])
    assert true_ranks(tied, np.array([0, 1])).tolist() == [1, 2]
    assert (true_ranks(tied, np.array([0, 1])) == 1).tolist() == (tied.argmax(axis=1) == [0, 1]).tolist()
    assert rank_histogram([1, 1, 2, 7, 6]) == "1×2 2×1 –×2"


def test_table1_rows_ranks_and_top1_rule_errors():
    # Alpha: 3 images, the 2nd predicted Beta (true rank 2); Gamma: 1 image, ranked beyond 5.
    probs = _probs([
        [0.9, 0.1, 0, 0, 0, 0, 0],
        [0.3, 0.7, 0, 0, 0, 0, 0],
        [0.8, 0.2, 0, 0, 0, 0, 0],
        [0.3, 0.2, 0.01, 0.1, 0.1, 0.1, 0.19],
    ])
    targets = np.array([0, 0, 0, 2])
    tables = evaluate_predictions(probs, targets, CLASSES, ["a1", "a2", "a3", "g1"], expected_top_k=2, first_n=4)
    t1 = tables.table1.set_index("model")
    assert list(t1.index) == ["Alpha", "Gamma"]  # models without test images get no row
    assert [t1.loc["Alpha", f"r{i}"] for i in range(1, 5)] == ["1", "2", "1", ""]
    assert t1.loc["Gamma", "r1"] == "–" and t1.loc["Gamma", "ranks"] == "–×1"
    assert t1.loc["Alpha", "top1_pct"] == pytest.approx(200 / 3)
    # top-1 rule: one of three Alpha images gets Beta's dims: |4600-4500|/4500 / 3
    assert t1.loc["Alpha", "L_err_pct_top1"] == pytest.approx(100 * 100 / 4500 / 3)
    assert t1.loc["Alpha", "H_err_pct_top1"] == pytest.approx(100 * 20 / 1450 / 3)
    # expected rule, top-2: first image 0.9*4500 + 0.1*4600 = 4510 -> 10 mm
    per_image = tables.per_image.set_index("image")
    assert per_image.loc["a1", "L_err_mm_expected"] == pytest.approx(10.0)
    assert per_image.loc["a2", "L_err_mm_top1"] == pytest.approx(100.0)
    assert t1.loc["Alpha", "L_mm"] == 4500 and t1.loc["Gamma", "H_mm"] == 1600


def test_accuracy_summary_and_confused_pairs():
    probs = _probs([[0.9, 0.1, 0, 0, 0, 0, 0], [0.3, 0.7, 0, 0, 0, 0, 0], [0.4, 0.6, 0, 0, 0, 0, 0],
                    [0.1, 0.1, 0.8, 0, 0, 0, 0]])
    targets = np.array([0, 0, 0, 2])
    tables = evaluate_predictions(probs, targets, CLASSES, list("abcd"))
    accuracy = tables.accuracy.set_index("metric")["value"]
    assert accuracy["top1_pct"] == pytest.approx(50.0)
    assert accuracy["top5_pct"] == pytest.approx(100.0)
    assert accuracy["per_class_top1_pct"] == pytest.approx((100 / 3 + 100) / 2)
    pairs = tables.confused_pairs
    assert len(pairs) == 1
    pair = pairs.iloc[0]
    assert (pair["true_model"], pair["pred_model"], pair["count"]) == ("Alpha", "Beta", 2)
    assert (pair["dL_mm"], pair["dW_mm"], pair["dH_mm"]) == (100.0, 50.0, 20.0)
    assert tables.confusion.sum() == 4 and tables.confusion[0, 1] == 2
    summary = tables.dimension_summary.set_index(["rule", "dimension"])
    assert summary.loc[("top1", "L"), "mean_mm"] == pytest.approx(50.0)
    assert summary.loc[("top1", "L"), "median_mm"] == pytest.approx(50.0)
    assert summary.loc[("top1", "L"), "p95_mm"] == pytest.approx(100.0)


def test_report_writes_csv_markdown_and_png(tmp_path):
    rng = np.random.default_rng(0)
    targets = np.repeat(np.arange(7), 12)
    probs = rng.dirichlet(np.ones(7), size=len(targets))
    probs[np.arange(len(targets)), targets] += 1.0
    probs /= probs.sum(axis=1, keepdims=True)
    tables = evaluate_predictions(probs, targets, CLASSES, [f"img{i}" for i in range(len(targets))])
    written = write_report(tables, CLASSES.names, tmp_path)
    names = {p.name for p in written}
    assert {"table1.csv", "accuracy.csv", "dimension_errors.csv", "confused_pairs.csv", "predictions.csv",
            "report.md", "confusion_matrix.png"} <= names
    assert (tmp_path / "confusion_matrix.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (tmp_path / "report.md").read_text()
    assert "| # | Vehicle model | 1 | 2 |" in report and "| 10 | all ranks |" in report
    assert pd.read_csv(tmp_path / "table1.csv")["images"].tolist() == [12] * 7
