"""Dimension error: the predicted model's length/width/height against the true model's."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vehloc.data.specs import DIMENSION_NAMES

if TYPE_CHECKING:
    import pandas as pd


@dataclass(frozen=True)
class DimensionErrors:
    """Per-image absolute (mm) and relative (%) errors, columns length, width, height."""

    abs_mm: np.ndarray
    rel_pct: np.ndarray

    def to_frame(self) -> pd.DataFrame:
        import pandas as pd  # imported on use: a CLI checks its input before loading pandas

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


def top_k_classes(probabilities: np.ndarray, k: int) -> np.ndarray:
    """(N, k) class indices of each row's k highest probabilities, highest first; ties go to the lower
    class index, so exactly k classes are kept."""
    probs = np.asarray(probabilities, dtype=float)
    return np.argsort(-probs, axis=1, kind="stable")[:, :k]


def expected_dims_mm(probabilities: np.ndarray, class_dims_mm: np.ndarray, top_k: int | None = None) -> np.ndarray:
    """Probability-weighted dimensions (N, 3) over exactly the top-k classes of each row (see
    `top_k_classes`; all classes when None), the k probabilities renormalised to sum to 1."""
    probs = np.asarray(probabilities, dtype=float)
    dims = np.asarray(class_dims_mm, dtype=float)
    k = probs.shape[1] if top_k is None else min(top_k, probs.shape[1])
    top = top_k_classes(probs, k)
    weights = np.take_along_axis(probs, top, axis=1)
    weights = weights / weights.sum(axis=1, keepdims=True)
    return np.einsum("nk,nkd->nd", weights, dims[top])
