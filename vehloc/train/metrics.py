"""torchmetrics for one split: top-1/top-5/per-class accuracy and the dimension error of the chosen model."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torchmetrics import Metric, MetricCollection
from torchmetrics.classification import MulticlassAccuracy

from vehloc.data.dimension_error import expected_dims_mm

DIMENSION_RULES = ("top1", "expected")


class DimensionError(Metric):
    """Mean relative error (%) of length, width and height of the dimensions estimated for each image,
    averaged over the three dimensions.

    rule `top1`: the paper's rule, the dimensions of the top-1 model; `expected`: probability-weighted
    dimensions over the top-k models.
    """

    full_state_update = False

    def __init__(self, class_dims_mm: Sequence[Sequence[float]], rule: str = "top1", top_k: int = 5) -> None:
        super().__init__()
        if rule not in DIMENSION_RULES:
            raise ValueError(f"rule {rule!r} not in {DIMENSION_RULES}")
        self.rule = rule
        self.top_k = top_k
        self.register_buffer("class_dims_mm", torch.as_tensor(class_dims_mm, dtype=torch.float64), persistent=False)
        self.add_state("rel_pct_sum", default=torch.zeros(3, dtype=torch.float64), dist_reduce_fx="sum")
        self.add_state("count", default=torch.tensor(0, dtype=torch.long), dist_reduce_fx="sum")

    def update(self, logits: torch.Tensor, target: torch.Tensor) -> None:
        dims = self.class_dims_mm.to(logits.device)
        if self.rule == "top1":
            pred_mm = dims[logits.argmax(dim=1)]
        else:
            probs = logits.detach().double().softmax(dim=1).cpu().numpy()
            expected = expected_dims_mm(probs, self.class_dims_mm.cpu().numpy(), self.top_k)
            pred_mm = torch.from_numpy(expected).to(dims)
        true_mm = dims[target]
        self.rel_pct_sum += (100.0 * (pred_mm - true_mm).abs() / true_mm).sum(dim=0)
        self.count += target.numel()

    def compute(self) -> torch.Tensor:
        return (self.rel_pct_sum / self.count.clamp(min=1)).mean().float()


def split_metrics(
    num_classes: int, class_dims_mm: Sequence[Sequence[float]] | None, prefix: str, top_k: int = 5
) -> MetricCollection:
    """Metrics of a split under `prefix` (`train/`, `val/`, `test/`); dimension errors when dims are given."""
    metrics: dict[str, Metric] = {
        "acc": MulticlassAccuracy(num_classes, top_k=1, average="micro"),
        "acc_top5": MulticlassAccuracy(num_classes, top_k=min(5, num_classes), average="micro"),
        "acc_macro": MulticlassAccuracy(num_classes, top_k=1, average="macro"),
    }
    if class_dims_mm is not None:
        metrics["dim_err_pct"] = DimensionError(class_dims_mm, "top1")
        metrics["dim_err_pct_expected"] = DimensionError(class_dims_mm, "expected", top_k)
    return MetricCollection(metrics, prefix=prefix)
