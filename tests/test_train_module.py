"""The LightningModule's pieces: the shared step's loss, the dimension-error metric, optimizer groups,
schedules, and atomic checkpoint writes."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from vehloc.train.checkpoint_io import AtomicCheckpointIO
from vehloc.train.metrics import DimensionError
from vehloc.train.module import LitVehicleClassifier
from vehloc.train.schedules import WarmupCosine, WarmupStep, param_groups
from vehloc.train.table1 import ClassTable, evaluate_predictions

DIMS_MM = [[4500.0, 1800.0, 1450.0], [4600.0, 1850.0, 1470.0], [4000.0, 1700.0, 1600.0]]


def make_classifier(**kwargs) -> LitVehicleClassifier:
    return LitVehicleClassifier(
        class_model_ids=[11, 12, 25], class_makes=["M", "M", "N"], class_models=["A", "B", "C"], class_dims_mm=DIMS_MM,
        backbone={"name": "googlenet", "pretrained": "none", "aux_logits": True},
        optimizer={"name": "sgd", "lr_backbone": 0.001, "lr_head": 0.01, "weight_decay": 1e-4},
        scheduler={"name": "cosine", "warmup_epochs": 1.0}, **kwargs,
    )


def test_training_loss_adds_weighted_auxiliary_losses():
    model = make_classifier(aux_loss_weight=0.3)
    images, targets = torch.rand(4, 3, 64, 64), torch.tensor([0, 1, 2, 0])
    model.train()
    torch.manual_seed(0)
    loss, logits, _ = model.model_step((images, targets))
    torch.manual_seed(0)
    out = model.net((images - model.mean) / model.std)
    expected = F.cross_entropy(out.logits, targets) + 0.3 * (
        F.cross_entropy(out.aux_logits1, targets) + F.cross_entropy(out.aux_logits2, targets))
    assert torch.allclose(loss, expected) and torch.allclose(logits, out.logits)
    model.eval()
    with torch.no_grad():
        eval_loss, eval_logits, _ = model.model_step((images, targets))
    assert torch.allclose(eval_loss, F.cross_entropy(eval_logits, targets))


def test_dimension_error_metric_matches_the_table1_computation():
    rng = np.random.default_rng(3)
    probs = rng.dirichlet(np.ones(3), size=20)
    targets = rng.integers(0, 3, size=20)
    tables = evaluate_predictions(probs, targets, ClassTable([11, 12, 25], ["A", "B", "C"], np.array(DIMS_MM)),
                                  [str(i) for i in range(20)], expected_top_k=2)
    logits = torch.log(torch.tensor(probs))
    for rule in ("top1", "expected"):
        metric = DimensionError(DIMS_MM, rule=rule, top_k=2)
        metric.update(logits[:7], torch.tensor(targets[:7]))
        metric.update(logits[7:], torch.tensor(targets[7:]))
        expected = tables.dimension_summary.query("rule == @rule")["mean_pct"].mean()
        assert metric.compute().item() == pytest.approx(expected, rel=1e-5)


def test_param_groups_split_head_backbone_and_decay():
    model = make_classifier()
    groups = param_groups(model.named_parameters(), model.head_prefixes, 0.001, 0.01, 1e-4)
    heads = ("net.fc.", "net.aux1.fc2.", "net.aux2.fc2.")
    head_ids = {id(p) for name, p in model.named_parameters() if name.startswith(heads)}
    for group in groups:
        in_head = {id(p) in head_ids for p in group["params"]}
        assert len(in_head) == 1
        assert group["lr"] == (0.01 if in_head.pop() else 0.001)
        assert group["weight_decay"] == (1e-4 if all(p.ndim > 1 for p in group["params"]) else 0.0)
    assert sum(len(g["params"]) for g in groups) == len(list(model.parameters()))


def test_warmup_cosine_and_step_schedules():
    cosine = WarmupCosine(warmup_steps=10, total_steps=110, start_factor=0.1, min_factor=0.0)
    assert cosine(0) == pytest.approx(0.1) and cosine(10) == pytest.approx(1.0)
    assert cosine(60) == pytest.approx(0.5) and cosine(110) == pytest.approx(0.0)
    step = WarmupStep(warmup_steps=0, step_size=30, gamma=0.1)
    assert [step(s) for s in (0, 29, 30, 65)] == pytest.approx([1.0, 1.0, 0.1, 0.01])


def test_atomic_checkpoint_write_keeps_the_old_file_when_saving_fails(tmp_path: Path):
    io = AtomicCheckpointIO()
    path = tmp_path / "checkpoints" / "last.ckpt"
    io.save_checkpoint({"epoch": 3, "w": torch.ones(2)}, path)
    good = path.read_bytes()
    with pytest.raises((AttributeError, TypeError, pickle.PicklingError)):
        io.save_checkpoint({"epoch": 4, "bad": lambda: None}, path)  # not picklable: fails mid-save
    assert path.read_bytes() == good
    assert [p.name for p in path.parent.iterdir()] == ["last.ckpt"]
    assert io.load_checkpoint(path)["epoch"] == 3
