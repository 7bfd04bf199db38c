"""The LightningModule: a backbone classifier over vehicle ROIs with one shared step and per-split metrics."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import lightning as L
import torch
import torch.nn.functional as F
from torch import nn
from torchmetrics import MaxMetric, MeanMetric

from vehloc.data.preprocess import Preprocessing
from vehloc.data.specs import display_name
from vehloc.errors import VehlocError
from vehloc.train.backbones import build_backbone
from vehloc.train.checkpoints import (  # noqa: F401 - re-exported: the checkpoint functions' earlier home
    PREPROCESSING_KEY,
    CheckpointError,
    check_classes,
    preprocessing_of,
    read_checkpoint,
)
from vehloc.train.metrics import split_metrics
from vehloc.train.params import ModelParams
from vehloc.train.schedules import build_optimizer, build_schedule, freeze_lowest_blocks, param_groups



class LitVehicleClassifier(L.LightningModule):
    """The LightningModule of the fine-grained vehicle-model classifier; input RGB float in [0, 1], output class
    logits.

    Hyperparameters are plain values (no objects), so checkpoints load with `weights_only=True` and carry
    the class table (model ids, names, dimensions in mm) with them, and the preprocessing under the
    checkpoint key `preprocessing`.
    """

    def __init__(
        self,
        class_model_ids: list[int],
        class_makes: list[str],
        class_models: list[str],
        class_dims_mm: list[list[float]],
        backbone: dict[str, Any],
        optimizer: dict[str, Any],
        scheduler: dict[str, Any],
        aux_loss_weight: float = 0.3,
        label_smoothing: float = 0.0,
        channels_last: bool = False,
        expected_top_k: int = 5,
        input_size_px: int = 224,
        eval_resize_px: int | None = None,
        roi_enlarge_fraction: float = 0.10,
        keep_aspect: bool = False,
        class_wheelbases_mm: list[float | None] | None = None,
        flip_average: bool = False,
        freeze_bn_stats: bool = False,
        layer_decay: float = 1.0,
        mixup_alpha: float = 0.0,
        frozen_blocks: int = 0,
    ) -> None:
        super().__init__()
        self.save_hyperparameters(logger=False)
        self.hparams.eval_resize_px = eval_resize_px or input_size_px
        num_classes = len(class_model_ids)
        if not (len(class_makes) == len(class_models) == len(class_dims_mm) == num_classes):
            raise VehlocError(
                f"class table mismatch: {num_classes} model ids, {len(class_makes)} makes, "
                f"{len(class_models)} models, {len(class_dims_mm)} dimension rows"
            )
        built = build_backbone(num_classes=num_classes, **backbone)
        self.net = built.net
        self.head_prefixes = tuple(f"net.{name}" for name in built.head_names)
        self.frozen_block_names = freeze_lowest_blocks(self.net, frozen_blocks, built.head_names)
        self.normalisation = (tuple(built.mean), tuple(built.std))
        self.register_buffer("mean", torch.tensor(built.mean).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(built.std).view(1, 3, 1, 1), persistent=False)
        if channels_last:
            self.net = self.net.to(memory_format=torch.channels_last)
        self.train_loss = MeanMetric()
        self.val_loss = MeanMetric()
        self.test_loss = MeanMetric()
        self.train_metrics = split_metrics(num_classes, None, "train/")
        self.val_metrics = split_metrics(num_classes, class_dims_mm, "val/", expected_top_k)
        self.test_metrics = split_metrics(num_classes, class_dims_mm, "test/", expected_top_k)
        self.val_acc_best = MaxMetric()

    @classmethod
    def from_params(cls, model: ModelParams, **class_info: Any) -> LitVehicleClassifier:
        """The classifier of checked settings (`vehloc.train.params.ModelParams`) for the classes of `class_info`
        (`CompCarsDataModule.class_info`): the one way the entry points build it. Its hyper-parameters are the
        settings as plain values, so that a checkpoint loads with `weights_only=True`."""
        return cls(**class_info, **dataclasses.asdict(model))

    @property
    def preprocessing(self) -> Preprocessing:
        """The one preprocessing of this classifier's input (ROI, resize, crop; the normalisation inside)."""
        hp = self.hparams
        return Preprocessing(int(hp.input_size_px), int(hp.eval_resize_px), float(hp.roi_enlarge_fraction),
                             *self.normalisation, bool(hp.keep_aspect))

    def on_save_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        checkpoint[PREPROCESSING_KEY] = self.preprocessing.as_dict()

    @property
    def num_classes(self) -> int:
        return len(self.hparams.class_model_ids)

    @property
    def class_names(self) -> list[str]:
        return [display_name(make, model) for make, model in zip(self.hparams.class_makes, self.hparams.class_models)]

    def _outputs(self, images: torch.Tensor) -> tuple[torch.Tensor, tuple[torch.Tensor, ...]]:
        x = (images - self.mean) / self.std
        if self.hparams.channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        out = self.net(x)
        if isinstance(out, tuple):
            return out[0], tuple(out[1:])
        return out, ()

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        """Class logits (N, C) of a batch of RGB images in [0, 1]; in evaluation with `flip_average`, the mean
        of the image's and its mirror image's (so the exported model averages too)."""
        logits = self._outputs(images)[0]
        if self.hparams.flip_average and not self.training:
            logits = (logits + self._outputs(images.flip(-1))[0]) / 2
        return logits

    def train(self, mode: bool = True) -> LitVehicleClassifier:
        """Training mode; the batch-norm layers of the frozen blocks, or all with `freeze_bn_stats`, keep
        normalising with their starting statistics."""
        super().train(mode)
        if not mode:
            return self
        blocks = [self.net] if self.hparams.freeze_bn_stats else [self.net.get_submodule(n)
                                                                  for n in self.frozen_block_names]
        for block in blocks:
            for module in block.modules():
                if isinstance(module, nn.modules.batchnorm._BatchNorm):
                    module.eval()
        return self

    def _loss(self, logits: torch.Tensor, aux: tuple[torch.Tensor, ...], targets: torch.Tensor) -> torch.Tensor:
        smoothing = self.hparams.label_smoothing
        loss = F.cross_entropy(logits, targets, label_smoothing=smoothing)
        for aux_logits in aux:
            loss = loss + self.hparams.aux_loss_weight * F.cross_entropy(aux_logits, targets, label_smoothing=smoothing)
        return loss

    def model_step(self, batch: tuple[torch.Tensor, ...]) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Loss (main + aux_loss_weight x each auxiliary head in training; mixup pairs with `mixup_alpha`),
        logits and targets of a batch."""
        images, targets = batch[0], batch[1]
        if not self.training:
            logits = self(images)
            return self._loss(logits, (), targets), logits, targets
        alpha = self.hparams.mixup_alpha
        if alpha <= 0:
            logits, aux = self._outputs(images)
            return self._loss(logits, aux, targets), logits, targets
        weight = float(torch.distributions.Beta(alpha, alpha).sample())
        partner = torch.randperm(images.shape[0], device=images.device)
        logits, aux = self._outputs(weight * images + (1 - weight) * images[partner])
        loss = weight * self._loss(logits, aux, targets) + (1 - weight) * self._loss(logits, aux, targets[partner])
        return loss, logits, targets

    def on_train_start(self) -> None:
        self.train()  # Lightning leaves the modules' modes as they are: apply freeze_bn_stats here
        self.val_loss.reset()
        self.val_metrics.reset()
        self.val_acc_best.reset()

    def training_step(self, batch: tuple[torch.Tensor, ...], batch_idx: int) -> torch.Tensor:
        loss, logits, targets = self.model_step(batch)
        self.train_loss(loss)
        self.train_metrics(logits.detach(), targets)
        self.log("train/loss", self.train_loss, on_step=False, on_epoch=True, prog_bar=True)
        self.log_dict(self.train_metrics, on_step=False, on_epoch=True, prog_bar=False)
        return loss

    def validation_step(self, batch: tuple[torch.Tensor, ...], batch_idx: int) -> None:
        loss, logits, targets = self.model_step(batch)
        self.val_loss(loss)
        self.val_metrics.update(logits, targets)
        self.log("val/loss", self.val_loss, on_step=False, on_epoch=True, prog_bar=True)

    def on_validation_epoch_end(self) -> None:
        values = self.val_metrics.compute()
        self.val_metrics.reset()
        acc = values.pop("val/acc")
        self.val_acc_best(acc)
        self.log_dict(values)
        self.log("val/acc", acc, prog_bar=True)
        self.log("val/acc_best", self.val_acc_best.compute(), prog_bar=True)

    def test_step(self, batch: tuple[torch.Tensor, ...], batch_idx: int) -> dict[str, torch.Tensor]:
        # Table 1 in full precision, as the exported model computes it, whatever precision trained the weights
        with torch.autocast(self.device.type, enabled=False):
            loss, logits, targets = self.model_step(batch)
        self.test_loss(loss)
        self.test_metrics.update(logits, targets)
        self.log("test/loss", self.test_loss, on_step=False, on_epoch=True)
        return {"probs": logits.float().softmax(dim=1), "targets": targets, "indices": batch[2]}

    def on_test_epoch_end(self) -> None:
        self.log_dict(self.test_metrics.compute())
        self.test_metrics.reset()

    def configure_optimizers(self) -> dict[str, Any]:
        opt = dict(self.hparams.optimizer)
        groups = param_groups(
            self.named_parameters(), self.head_prefixes, opt.pop("lr_backbone"), opt.pop("lr_head"),
            opt.pop("weight_decay", 0.0), self.hparams.layer_decay,
        )
        optimizer = build_optimizer(groups, **opt)
        total_steps = int(self.trainer.estimated_stepping_batches)
        steps_per_epoch = max(1, total_steps // max(1, self.trainer.max_epochs or 1))
        factor = build_schedule(total_steps=total_steps, steps_per_epoch=steps_per_epoch, **self.hparams.scheduler)
        if factor is None:
            return {"optimizer": optimizer}
        scheduler = torch.optim.lr_scheduler.LambdaLR(optimizer, factor)
        return {"optimizer": optimizer, "lr_scheduler": {"scheduler": scheduler, "interval": "step"}}


def load_classifier(checkpoint: dict[str, Any], source: str | Path = "checkpoint", **overrides: Any) -> LitVehicleClassifier:
    """Rebuild the classifier of a checkpoint (backbone not re-initialised from pretrained weights; hparams
    in `overrides` replaced) and load its weights."""
    hparams = {**checkpoint["hyper_parameters"], **overrides}
    hparams["backbone"] = {**hparams["backbone"], "pretrained": "none"}
    try:
        model = LitVehicleClassifier(**hparams)
        model.load_state_dict(checkpoint["state_dict"])
    except (TypeError, RuntimeError, KeyError) as err:
        raise CheckpointError(
            f"{source}: the checkpoint's weights do not fit the network it describes "
            f"({str(err).splitlines()[0][:200]})") from None
    return model
