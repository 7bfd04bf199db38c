"""The paper's Table 1 and the evaluation tables, from test-set class probabilities (pure functions).

Rank of the true model: 1 + the number of classes with a higher probability (and of those with an equal one
before it in class order, as argmax breaks ties); ranks beyond `MAX_RANK`
are written "–" as in the paper. Two dimension rules: `top1` (the paper's: the dimensions of the top-1
model) and `expected` (probability-weighted dimensions over the top-k models).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from vehloc.data.dimension_error import dimension_errors, expected_dims_mm

MAX_RANK = 5
BEYOND = "–"
DIMS = ("L", "W", "H")


@dataclass(frozen=True)
class ClassTable:
    """The classes of a classifier, in class-index order."""

    model_ids: Sequence[int]
    names: Sequence[str]
    dims_mm: np.ndarray  # (C, 3) length, width, height

    def __post_init__(self) -> None:
        if not (len(self.model_ids) == len(self.names) == len(self.dims_mm)):
            raise ValueError("model ids, names and dimensions differ in length")


@dataclass(frozen=True)
class EvalTables:
    per_image: pd.DataFrame
    table1: pd.DataFrame
    accuracy: pd.DataFrame
    dimension_summary: pd.DataFrame
    confused_pairs: pd.DataFrame
    confusion: np.ndarray  # (C, C) counts, rows true, columns predicted


def true_ranks(probs: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """1-based rank of the true class in each row of `probs`, classes of equal probability in index order (as
    `argmax` takes the first): rank 1 exactly when the row's argmax is the true class."""
    true_p = probs[np.arange(len(targets)), targets]
    tied_before = (probs == true_p[:, None]) & (np.arange(probs.shape[1])[None, :] < targets[:, None])
    return 1 + (probs > true_p[:, None]).sum(axis=1) + tied_before.sum(axis=1)


def rank_label(rank: int) -> str:
    return str(rank) if rank <= MAX_RANK else BEYOND


def rank_histogram(ranks: Sequence[int]) -> str:
    """Compact counts of rank labels, e.g. `1×8 2×1 –×1`."""
    counts = Counter(rank_label(int(r)) for r in ranks)
    order = [str(r) for r in range(1, MAX_RANK + 1)] + [BEYOND]
    return " ".join(f"{label}×{counts[label]}" for label in order if counts[label])


def _dimension_rules(probs: np.ndarray, targets: np.ndarray, classes: ClassTable, top_k: int) -> dict:
    true_mm = classes.dims_mm[targets]
    return {
        "top1": dimension_errors(classes.dims_mm[probs.argmax(axis=1)], true_mm),
        "expected": dimension_errors(expected_dims_mm(probs, classes.dims_mm, top_k), true_mm),
    }


def per_image_frame(
    probs: np.ndarray, targets: np.ndarray, classes: ClassTable, images: Sequence[str], top_k: int
) -> pd.DataFrame:
    """One row per test image: true model, rank, top-5 predictions, dimension errors of both rules."""
    ranks = true_ranks(probs, targets)
    order = np.argsort(-probs, axis=1)[:, :MAX_RANK]
    frame = pd.DataFrame({
        "image": list(images),
        "true_model_id": [classes.model_ids[t] for t in targets],
        "true_model": [classes.names[t] for t in targets],
        "rank": ranks,
        "pred_model_id": [classes.model_ids[o[0]] for o in order],
        "pred_model": [classes.names[o[0]] for o in order],
        "pred_prob": probs[np.arange(len(targets)), order[:, 0]],
        "top5_model_ids": [" ".join(str(classes.model_ids[i]) for i in o) for o in order],
    })
    for rule, errors in _dimension_rules(probs, targets, classes, top_k).items():
        for i, dim in enumerate(DIMS):
            frame[f"{dim}_err_mm_{rule}"] = errors.abs_mm[:, i]
            frame[f"{dim}_err_pct_{rule}"] = errors.rel_pct[:, i]
    return frame


def table1_frame(per_image: pd.DataFrame, classes: ClassTable, first_n: int = 10) -> pd.DataFrame:
    """Per true model: ranks of its first `first_n` images, a rank histogram of all, top-1/top-5 accuracy,
    real L/W/H (mm) and the average L/W/H % error of each dimension rule."""
    rows = []
    for index, (model_id, name) in enumerate(zip(classes.model_ids, classes.names)):
        group = per_image[per_image["true_model_id"] == model_id]
        if group.empty:
            continue
        ranks = group["rank"].to_numpy()
        row: dict[str, object] = {"#": len(rows) + 1, "model_id": model_id, "model": name, "images": len(group)}
        for i in range(first_n):
            row[f"r{i + 1}"] = rank_label(int(ranks[i])) if i < len(ranks) else ""
        row["ranks"] = rank_histogram(ranks)
        row["top1_pct"] = 100.0 * float(np.mean(ranks == 1))
        row["top5_pct"] = 100.0 * float(np.mean(ranks <= MAX_RANK))
        for dim, value in zip(DIMS, classes.dims_mm[index]):
            row[f"{dim}_mm"] = float(value)
        for rule in ("top1", "expected"):
            for dim in DIMS:
                row[f"{dim}_err_pct_{rule}"] = float(group[f"{dim}_err_pct_{rule}"].mean())
        rows.append(row)
    return pd.DataFrame(rows)


def accuracy_frame(per_image: pd.DataFrame, num_classes: int) -> pd.DataFrame:
    ranks = per_image["rank"].to_numpy()
    per_class = per_image.assign(hit=ranks == 1).groupby("true_model_id")["hit"].mean()
    return pd.DataFrame([
        {"metric": "images", "value": float(len(ranks))},
        {"metric": "classes", "value": float(num_classes)},
        {"metric": "top1_pct", "value": 100.0 * float(np.mean(ranks == 1))},
        {"metric": "top5_pct", "value": 100.0 * float(np.mean(ranks <= MAX_RANK))},
        {"metric": "per_class_top1_pct", "value": 100.0 * float(per_class.mean())},
    ])


def dimension_summary_frame(per_image: pd.DataFrame) -> pd.DataFrame:
    """Mean, median and 95th percentile of the L/W/H errors in mm and %, per rule."""
    rows = []
    for rule in ("top1", "expected"):
        for dim in DIMS:
            mm = per_image[f"{dim}_err_mm_{rule}"].to_numpy()
            pct = per_image[f"{dim}_err_pct_{rule}"].to_numpy()
            rows.append({
                "rule": rule, "dimension": dim,
                "mean_mm": mm.mean(), "median_mm": np.median(mm), "p95_mm": np.percentile(mm, 95),
                "mean_pct": pct.mean(), "median_pct": np.median(pct), "p95_pct": np.percentile(pct, 95),
            })
    return pd.DataFrame(rows)


def confusion_counts(probs: np.ndarray, targets: np.ndarray, num_classes: int) -> np.ndarray:
    matrix = np.zeros((num_classes, num_classes), dtype=np.int64)
    np.add.at(matrix, (targets, probs.argmax(axis=1)), 1)
    return matrix


def confused_pairs_frame(confusion: np.ndarray, classes: ClassTable, top_n: int = 10) -> pd.DataFrame:
    """The most frequent (true, predicted) mistakes with the predicted-minus-true dimension differences."""
    off = confusion.copy()
    np.fill_diagonal(off, 0)
    true_idx, pred_idx = np.nonzero(off)
    order = np.argsort(-off[true_idx, pred_idx], kind="stable")[:top_n]
    rows = []
    for t, p in zip(true_idx[order], pred_idx[order]):
        diff_mm = classes.dims_mm[p] - classes.dims_mm[t]
        row = {
            "true_model_id": classes.model_ids[t], "true_model": classes.names[t],
            "pred_model_id": classes.model_ids[p], "pred_model": classes.names[p],
            "count": int(off[t, p]), "share_of_true_pct": 100.0 * off[t, p] / confusion[t].sum(),
        }
        for i, dim in enumerate(DIMS):
            row[f"d{dim}_mm"] = float(diff_mm[i])
        for i, dim in enumerate(DIMS):
            row[f"d{dim}_pct"] = float(100.0 * diff_mm[i] / classes.dims_mm[t][i])
        rows.append(row)
    columns = ["true_model_id", "true_model", "pred_model_id", "pred_model", "count", "share_of_true_pct",
               *(f"d{d}_mm" for d in DIMS), *(f"d{d}_pct" for d in DIMS)]
    return pd.DataFrame(rows, columns=columns)


def evaluate_predictions(
    probs: np.ndarray,
    targets: np.ndarray,
    classes: ClassTable,
    images: Sequence[str],
    expected_top_k: int = 5,
    first_n: int = 10,
    top_pairs: int = 10,
) -> EvalTables:
    """All evaluation tables from (N, C) probabilities and (N,) true class indices."""
    probs = np.asarray(probs, dtype=float)
    targets = np.asarray(targets, dtype=int)
    if probs.shape != (len(targets), len(classes.model_ids)):
        raise ValueError(
            f"probabilities {probs.shape} do not match {len(targets)} targets x {len(classes.model_ids)} classes"
        )
    per_image = per_image_frame(probs, targets, classes, images, expected_top_k)
    confusion = confusion_counts(probs, targets, len(classes.model_ids))
    return EvalTables(
        per_image=per_image,
        table1=table1_frame(per_image, classes, first_n),
        accuracy=accuracy_frame(per_image, len(classes.model_ids)),
        dimension_summary=dimension_summary_frame(per_image),
        confused_pairs=confused_pairs_frame(confusion, classes, top_pairs),
        confusion=confusion,
    )
