"""Lightning callbacks of the workbench: the Table 1 writer run after every test loop, and the exponential
moving average of the weights."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import lightning as L
import numpy as np
import torch
from lightning.pytorch.callbacks import EMAWeightAveraging
from lightning.pytorch.utilities import rank_zero_info

from vehloc.config import check_range
from vehloc.train.precision import device_description
from vehloc.train.report import write_report
from vehloc.train.table1 import ClassTable, evaluate_predictions


class Table1Writer(L.Callback):
    """Collect the test split's class probabilities (from every process) and write Table 1, the accuracy and
    dimension-error tables, the most-confused pairs and the confusion matrix into `out_dir`."""

    def __init__(self, out_dir: str, expected_top_k: int = 5, first_n: int = 10, top_pairs: int = 10) -> None:
        self.out_dir = Path(out_dir)
        self.expected_top_k = expected_top_k
        self.first_n = first_n
        self.top_pairs = top_pairs
        self._batches: list[dict[str, torch.Tensor]] = []
        self.written: list[Path] = []

    def on_test_epoch_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self._batches = []

    def on_test_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs: Any, batch: Any,
                          batch_idx: int, dataloader_idx: int = 0) -> None:
        self._batches.append({k: v.detach() for k, v in outputs.items()})

    def _gathered(self, pl_module: L.LightningModule) -> dict[str, np.ndarray]:
        local = {k: torch.cat([b[k] for b in self._batches]) for k in ("probs", "targets", "indices")}
        if pl_module.trainer.world_size > 1:
            local = {k: pl_module.all_gather(v).flatten(0, 1) for k, v in local.items()}
        _, first = np.unique(local["indices"].cpu().numpy(), return_index=True)
        return {k: v.cpu().numpy()[first] for k, v in local.items()}

    def on_test_epoch_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        if not self._batches:
            return
        data = self._gathered(pl_module)
        if not trainer.is_global_zero:
            return
        hp = pl_module.hparams
        classes = ClassTable(hp.class_model_ids, pl_module.class_names, np.asarray(hp.class_dims_mm, dtype=float))
        samples = trainer.datamodule.test_set.samples
        images = [samples[i].rel_path for i in data["indices"]]
        tables = evaluate_predictions(
            data["probs"], data["targets"], classes, images, self.expected_top_k, self.first_n, self.top_pairs
        )
        device = device_description(gpu=trainer.strategy.root_device.type == "cuda")
        self.written = write_report(tables, classes.names, self.out_dir, title="Evaluation on the test split",
                                    run_line=f"Precision {trainer.precision} on {device}.",
                                    warning=trainer.datamodule.test_split_warning)
        rank_zero_info(f"Table 1 and evaluation tables written to {self.out_dir}")


class WeightEMA(EMAWeightAveraging):
    """Exponential moving average of the weights (and batch-norm statistics), updated after every training
    step: validation, the checkpoints' `state_dict`, the test and so the export all use the average.

    Lightning's callback puts the training weights back when any checkpoint is loaded; here that happens only
    when a fit resumes, so the test of the best checkpoint runs on the average it was chosen with.
    """

    def __init__(self, decay: float = 0.99, **kwargs: Any) -> None:
        check_range("decay", decay, 0.0, 1.0, low_open=True, high_open=True)
        super().__init__(decay=decay, **kwargs)

    def on_load_checkpoint(self, trainer: L.Trainer, pl_module: L.LightningModule, checkpoint: dict[str, Any]) -> None:
        if trainer.state.fn == "fit":
            super().on_load_checkpoint(trainer, pl_module, checkpoint)
