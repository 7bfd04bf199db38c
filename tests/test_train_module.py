"""The LightningModule's pieces: the shared step's loss, the dimension-error metric, optimizer groups,
schedules, and atomic checkpoint writes."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F

from vehloc.errors import VehlocError
from vehloc.train.checkpoint_io import AtomicCheckpointIO
from vehloc.train.metrics import DimensionError
from vehloc.train.module import LitVehicleClassifier
from vehloc.train.schedules import WarmupCosine, WarmupStep, block_depths, param_groups
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


def test_layer_decay_scales_each_backbone_block_below_the_top_one():
    assert block_depths(["net.conv1.weight", "net._blocks.0.a.weight", "net._blocks.0.b.weight",
                         "net._blocks.1.a.weight", "net.layer1.0.conv.weight", "net.head.weight"]) == [0, 1, 1, 2, 3, 4]
    model = make_classifier()
    groups = param_groups(model.named_parameters(), model.head_prefixes, 0.001, 0.01, 1e-4, layer_decay=0.5)
    lr_of = {id(p): g["lr"] for g in groups for p in g["params"]}
    params = dict(model.named_parameters())
    # GoogLeNet's blocks in registration order: conv1-3, inception 3a-5b (9), then the auxiliary branches aux1, aux2
    assert lr_of[id(params["net.conv1.conv.weight"])] == pytest.approx(0.001 * 0.5 ** 13)
    assert lr_of[id(params["net.inception5b.branch1.conv.weight"])] == pytest.approx(0.001 * 0.5 ** 2)
    assert lr_of[id(params["net.aux2.fc1.weight"])] == pytest.approx(0.001)
    assert lr_of[id(params["net.fc.weight"])] == 0.01
    assert sum(len(g["params"]) for g in groups) == len(params)


def test_flip_average_evaluates_the_mean_of_the_image_and_its_mirror():
    torch.manual_seed(0)
    model = make_classifier(flip_average=True).eval()
    plain = make_classifier(flip_average=False).eval()
    plain.load_state_dict(model.state_dict())
    images = torch.rand(2, 3, 64, 64)
    with torch.no_grad():
        expected = (plain(images) + plain(images.flip(-1))) / 2
        torch.testing.assert_close(model(images), expected)           # float32 tolerance
        torch.testing.assert_close(model(images.flip(-1)), model(images))
        assert not torch.allclose(plain(images.flip(-1)), plain(images))
        model.train()
        assert len(model._outputs(images)[1]) == 2  # training still sees one view, with its auxiliary heads


def test_freeze_bn_stats_keeps_the_starting_statistics_while_training():
    images, targets = torch.rand(4, 3, 64, 64), torch.tensor([0, 1, 2, 0])
    for freeze in (True, False):
        model = make_classifier(freeze_bn_stats=freeze)
        model.train()
        bn = model.net.conv1.bn
        assert bn.training is not freeze and model.training
        before = bn.running_mean.clone()
        model.model_step((images, targets))[0].backward()
        assert torch.equal(bn.running_mean, before) is freeze
        assert model.net.conv1.bn.weight.grad is not None


def test_frozen_blocks_keep_their_weights_and_statistics_while_the_blocks_above_learn():
    torch.manual_seed(0)
    model = make_classifier(frozen_blocks=3)  # GoogLeNet's conv1, conv2, conv3
    assert model.frozen_block_names == ["conv1", "conv2", "conv3"]
    before = {name: p.detach().clone() for name, p in model.named_parameters()}
    stats_before = model.net.conv3.bn.running_mean.clone()
    optimizer = torch.optim.SGD([p for p in model.parameters() if p.requires_grad], lr=0.1)
    model.train()
    assert not model.net.conv3.bn.training and model.net.inception3a.branch1.bn.training
    model.model_step((torch.rand(4, 3, 64, 64), torch.tensor([0, 1, 2, 0])))[0].backward()
    optimizer.step()
    changed = {name for name, p in model.named_parameters() if not torch.equal(p, before[name])}
    assert not any(name.startswith(("net.conv1.", "net.conv2.", "net.conv3.")) for name in changed)
    assert "net.inception3a.branch1.conv.weight" in changed and "net.fc.weight" in changed
    assert torch.equal(model.net.conv3.bn.running_mean, stats_before)
    groups = param_groups(model.named_parameters(), model.head_prefixes, 0.001, 0.01, 1e-4)
    assert sum(len(g["params"]) for g in groups) == sum(p.requires_grad for p in model.parameters())


def test_more_frozen_blocks_than_the_backbone_has_is_refused():
    with pytest.raises(VehlocError, match="model.frozen_blocks: 15 is more than the backbone's 14 blocks"):
        make_classifier(frozen_blocks=15)


def test_mixup_loss_weighs_both_partners_targets():
    model = make_classifier(mixup_alpha=0.4, aux_loss_weight=0.0)
    model.train()
    images, targets = torch.rand(4, 3, 64, 64), torch.tensor([0, 1, 2, 0])
    torch.manual_seed(3)
    loss, logits, returned = model.model_step((images, targets))
    torch.manual_seed(3)
    weight = float(torch.distributions.Beta(0.4, 0.4).sample())
    partner = torch.randperm(4)
    assert 0.0 < weight < 1.0 and not torch.equal(partner, torch.arange(4))
    expected = (weight * torch.nn.functional.cross_entropy(logits, targets)
                + (1 - weight) * torch.nn.functional.cross_entropy(logits, targets[partner]))
    torch.testing.assert_close(loss, expected)
    assert torch.equal(returned, targets)
