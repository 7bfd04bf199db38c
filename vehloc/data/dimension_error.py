"""Dimension error: the predicted model's length/width/height against the true model's."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from vehloc.data.specs import DIMENSION_NAMES


@dataclass(frozen=True)
class DimensionErrors:
    """Per-image absolute (mm) and relative (%) errors, columns length, width, height."""

    abs_mm: np.ndarray
    rel_pct: np.ndarray

    def to_frame(self) -> pd.DataFrame:
        columns = {f"{d}_err_mm": self.abs_mm[:, i] for i, d in enumerate(DIMENSION_NAMES)}
        columns |= {f"{d}_err_pct": self.rel_pct[:, i] for i, d in enumerate(DIMENSION_NAMES)}
        return pd.DataFrame(columns)


def dimension_errors(pred_dims_mm: np.ndarray, true_dims_mm: np.ndarray) -> DimensionErrors:
    """Absolute and relative error of predicted (N, 3) dimensions against the true (N, 3) ones."""
    pred = np.asarray(pred_dims_mm, dtype=float).reshape(-1, 3)
    true = np.asarray(true_dims_mm, dtype=float).reshape(-1, 3)
    if pred.shape != true.shape:
        raise ValueError(f"predicted dims {pred.shape} and true dims {true.shape} differ in shape")
    if np.any(true <= 0):
        raise ValueError("true dimensions must be positive")
    abs_mm = np.abs(pred - true)
    return DimensionErrors(abs_mm=abs_mm, rel_pct=100.0 * abs_mm / true)


def expected_dims_mm(probabilities: np.ndarray, class_dims_mm: np.ndarray, top_k: int | None = None) -> np.ndarray:
    """Probability-weighted dimensions (N, 3), over the top-k classes of each row (all when None)."""
    probs = np.asarray(probabilities, dtype=float)
    if top_k is not None and top_k < probs.shape[1]:
        cutoff = np.sort(probs, axis=1)[:, -top_k][:, None]
        probs = np.where(probs >= cutoff, probs, 0.0)
    probs = probs / probs.sum(axis=1, keepdims=True)
    return probs @ np.asarray(class_dims_mm, dtype=float)
