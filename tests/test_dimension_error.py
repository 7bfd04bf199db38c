"""Dimension error of the predicted model against the true model, and the expected-dimension rule."""

from __future__ import annotations

import numpy as np
import pytest

from vehloc.data.dimension_error import dimension_errors, expected_dims_mm, top_k_classes

BMW7 = [5250, 1902, 1498]
BENZ_S = [5250, 1899, 1494]
BENZ_R = [5159, 1922, 1663]


def test_paper_row_benz_s_confused_with_bmw7() -> None:
    errors = dimension_errors(np.array([BMW7, BENZ_S]), np.array([BENZ_S, BENZ_S]))
    np.testing.assert_allclose(errors.abs_mm, [[0, 3, 4], [0, 0, 0]])
    np.testing.assert_allclose(errors.rel_pct[0], [0, 300 / 1899, 400 / 1494], rtol=1e-12)
    frame = errors.to_frame()
    assert list(frame.columns) == [
        "length_err_mm", "width_err_mm", "height_err_mm", "length_err_pct", "width_err_pct", "height_err_pct",
    ]
    assert frame.loc[0, "height_err_mm"] == 4


def test_shape_and_value_checks() -> None:
    with pytest.raises(ValueError, match="differ in shape"):
        dimension_errors(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="must be positive"):
        dimension_errors(np.ones((1, 3)), np.zeros((1, 3)))


def test_expected_dims_weighted_over_top_k() -> None:
    class_dims = np.array([BMW7, BENZ_S, BENZ_R], dtype=float)
    probs = np.array([[0.5, 0.3, 0.2], [0.0, 1.0, 0.0]])
    full = expected_dims_mm(probs, class_dims)
    np.testing.assert_allclose(full[0], 0.5 * class_dims[0] + 0.3 * class_dims[1] + 0.2 * class_dims[2])
    np.testing.assert_allclose(full[1], BENZ_S)
    top2 = expected_dims_mm(probs, class_dims, top_k=2)
    np.testing.assert_allclose(top2[0], (0.5 * class_dims[0] + 0.3 * class_dims[1]) / 0.8)


def test_expected_dims_keep_exactly_k_classes_on_ties() -> None:
    """Three classes tied at 0.3 with k = 2: the two of lower index, not all three."""
    class_dims = np.array([BMW7, BENZ_S, BENZ_R, [4000.0, 1700.0, 1400.0]], dtype=float)
    probs = np.array([[0.3, 0.3, 0.3, 0.1]])
    np.testing.assert_allclose(expected_dims_mm(probs, class_dims, top_k=2)[0], (class_dims[0] + class_dims[1]) / 2)
    assert top_k_classes(probs, 3).tolist() == [[0, 1, 2]]


def test_the_validation_metric_and_table1_use_the_same_expected_dims() -> None:
    """The torchmetrics DimensionError (rule `expected`) on logits equals Table 1's NumPy computation."""
    import torch

    from vehloc.train.metrics import DimensionError

    class_dims = np.array([BMW7, BENZ_S, BENZ_R, [4000.0, 1700.0, 1400.0]], dtype=float)
    logits = torch.tensor([[2.0, 2.0, 2.0, 0.0], [0.1, 3.0, -1.0, 0.5]], dtype=torch.float64)
    targets = torch.tensor([0, 1])
    metric = DimensionError(class_dims.tolist(), "expected", top_k=2)
    metric.update(logits, targets)
    probs = logits.softmax(dim=1).numpy()
    expected = expected_dims_mm(probs, class_dims, top_k=2)
    table = dimension_errors(expected, class_dims[targets.numpy()]).rel_pct.mean()
    assert float(metric.compute()) == pytest.approx(table, rel=1e-6)
