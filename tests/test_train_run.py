"""Training runs on the tiny data set: fast_dev_run, overfitting a batch, resuming, DDP on CPU, multirun,
and bad input giving one clear line and a non-zero exit."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import lightning as L
import pandas as pd
import pytest
import torch

from vehloc.hardware import cpu_info
from vehloc.train.instantiate import compose_config
from vehloc.train.train import train

pytestmark = pytest.mark.slow  # trains small networks end to end

PROJECT_ROOT = Path(__file__).resolve().parents[1]


def tiny_overrides(root: Path, *extra: str) -> list[str]:
    return [
        f"data.root={root}", "data.input_size_px=32", "data.eval_resize_px=32", "data.batch_size=4",
        "data.num_workers=0", "model.backbone.pretrained=none", "trainer.max_epochs=1",
        "callbacks.model_summary.max_depth=0", *extra,
    ]


class KillMidEpoch(L.Callback):
    """Stands in for a run killed during epoch `epoch`, after `batches` of its batches."""

    def __init__(self, epoch: int, batches: int) -> None:
        self.epoch, self.batches = epoch, batches

    def on_train_batch_end(self, trainer, pl_module, outputs, batch, batch_idx) -> None:
        if trainer.current_epoch == self.epoch and batch_idx + 1 == self.batches:
            raise RuntimeError("killed")


class RecordStart(L.Callback):
    """Records the state the trainer starts fitting from."""

    seen: dict = {}

    def on_train_start(self, trainer, pl_module) -> None:
        optimizer = trainer.optimizers[0]
        RecordStart.seen = {
            "epoch": trainer.current_epoch,
            "global_step": trainer.global_step,
            "momentum": {i: s["momentum_buffer"].clone() for i, s in enumerate(optimizer.state.values())},
            "scheduler_last_epoch": trainer.lr_scheduler_configs[0].scheduler.last_epoch,
            "fc_weight": pl_module.net.fc.weight.detach().clone(),
        }


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def error_lines(stderr: str, prog: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith(f"{prog}: error:")]


@pytest.mark.parametrize("extra", [[], ["model.channels_last=true", "trainer.precision=bf16-mixed",
                                          "model.optimizer.name=adamw", "model.scheduler.name=step",
                                          "data.val_fraction=0", "data.select_on_test=true"]])
def test_fast_dev_run_trains_tests_and_writes_table1(extra: list[str], tiny_root: Path, tmp_path: Path):
    cfg = compose_config("train", tiny_overrides(tiny_root, "debug=fdr", *extra), tmp_path)
    metrics, objects = train(cfg)
    assert {"train/loss", "val/acc", "val/acc_best", "test/acc", "test/acc_top5", "test/dim_err_pct",
            "test/dim_err_pct_expected"} <= set(metrics)
    assert 0.0 <= metrics["test/acc"] <= metrics["test/acc_top5"] <= 1.0
    table1 = pd.read_csv(tmp_path / "table1" / "table1.csv")
    assert table1["model_id"].tolist() == [11, 12, 25] and table1["images"].tolist() == [1, 1, 1]
    assert (tmp_path / "table1" / "confusion_matrix.png").is_file()
    assert objects["trainer"].fast_dev_run
    precision = objects["trainer"].precision
    report = (tmp_path / "table1" / "report.md").read_text()
    assert f"Precision {precision} on {cpu_info().model_name}" in report
    selected_on_test = "data.select_on_test=true" in extra
    assert report.splitlines()[0].startswith("**Optimistic" if selected_on_test else "# Evaluation")


@pytest.mark.parametrize("freeze", [True, False])
def test_freeze_bn_stats_holds_through_a_lightning_fit(freeze: bool, tiny_root: Path, tmp_path: Path):
    """With model.freeze_bn_stats=true the batch-norm statistics a fit starts from are those it ends with."""
    cfg = compose_config("train", tiny_overrides(tiny_root, "debug=fdr", f"model.freeze_bn_stats={freeze}", "test=false"),
                         tmp_path)
    _, objects = train(cfg)
    bn = objects["model"].net.conv1.bn
    assert (int(bn.num_batches_tracked) == 0) is freeze
    assert bool(torch.all(bn.running_mean == 0)) is freeze  # a fresh network's statistics: mean 0


def test_overfitting_one_batch_learns_it(tiny_root: Path, tmp_path: Path):
    """The six train images (nine less the validation carve-out), the same batch 40 times, the learning rate
    annealed to zero: the loss falls to a small fraction of where it started and every image of the batch is
    predicted right. Over seeds 0-7 on an AMD EPYC (fp32), with all nine images in the batch, the final loss was
    0.0005-0.03 of the first epoch's and the last five epochs were all 9/9: the bounds leave a wide margin."""
    cfg = compose_config("train", tiny_overrides(
        tiny_root, "debug=overfit", "trainer.max_epochs=40", "test=false", "data.batch_size=9",
        "data.augment.crop_scale=[1.0,1.0]", "data.augment.hflip=false", "data.augment.color_jitter=0",
        "model.optimizer.name=adamw", "model.optimizer.lr_backbone=0.002", "model.optimizer.lr_head=0.002",
        "model.optimizer.weight_decay=0", "model.scheduler.name=cosine", "model.scheduler.warmup_epochs=0",
        "~callbacks.model_checkpoint", "~callbacks.last_checkpoint", "+trainer.enable_checkpointing=false",
    ), tmp_path)
    train(cfg)
    history = pd.read_csv(tmp_path / "csv" / "metrics.csv").dropna(subset=["train/loss"])
    loss, accuracy = history["train/loss"].to_numpy(), history["train/acc"].to_numpy()
    assert len(loss) == 40
    assert loss[0] > 1.0  # main + 0.3 x two auxiliary cross-entropies of 3 classes, ln 3 = 1.10 each
    assert loss[-1] < 0.2 * loss[0]
    assert accuracy[-1] == 1.0  # the last epoch's batch: all 9 images predicted right


def test_a_killed_run_resumes_from_last_with_optimizer_scheduler_and_epoch(tiny_root: Path, tmp_path: Path):
    first = tmp_path / "first"
    kill = ["+callbacks.kill._target_=test_train_run.KillMidEpoch", "+callbacks.kill.epoch=1",
            "+callbacks.kill.batches=1"]
    cfg = compose_config("train", tiny_overrides(tiny_root, "trainer.max_epochs=3", "data.batch_size=3", *kill), first)
    with pytest.raises(RuntimeError, match="killed"):
        train(cfg)
    last = first / "checkpoints" / "last.ckpt"
    saved = torch.load(last, map_location="cpu", weights_only=True)
    # epoch 0 completed: 6 images (9 less the validation carve-out of one a model), 3 a batch
    assert saved["epoch"] == 0 and saved["global_step"] == 2
    digest = hashlib.sha256(last.read_bytes()).hexdigest()
    assert not list(first.glob("checkpoints/.*.tmp"))

    second = tmp_path / "second"
    record = ["+callbacks.record._target_=test_train_run.RecordStart"]
    cfg = compose_config("train", tiny_overrides(
        tiny_root, "trainer.max_epochs=3", "data.batch_size=3", f"ckpt_path={last}", *record), second)
    _, objects = train(cfg)
    seen = RecordStart.seen
    assert seen["epoch"] == 1 and seen["global_step"] == 2
    saved_state = saved["optimizer_states"][0]["state"]
    assert len(seen["momentum"]) == len(saved_state) > 0
    for index, buffer in enumerate(seen["momentum"].values()):
        assert torch.equal(buffer, saved_state[index]["momentum_buffer"])
    assert seen["scheduler_last_epoch"] == saved["lr_schedulers"][0]["last_epoch"] == 2
    assert torch.equal(seen["fc_weight"], saved["state_dict"]["net.fc.weight"])
    assert objects["trainer"].current_epoch == 3 and objects["trainer"].global_step == 6
    resumed = pd.read_csv(second / "csv" / "metrics.csv")
    assert sorted(resumed.dropna(subset=["train/loss"])["epoch"].astype(int)) == [1, 2]
    assert hashlib.sha256(last.read_bytes()).hexdigest() == digest  # the source checkpoint is untouched


def test_last_checkpoint_follows_every_epoch_while_the_best_stays_behind(tiny_root: Path, tmp_path: Path):
    """The best checkpoint monitors `epoch` with mode min, so epoch 0 stays best; last.ckpt still holds epoch 2."""
    cfg = compose_config("train", tiny_overrides(
        tiny_root, "trainer.max_epochs=3", "data.batch_size=3", "test=false",
        "callbacks.model_checkpoint.monitor=epoch", "callbacks.model_checkpoint.mode=min"), tmp_path)
    train(cfg)
    saved = sorted(p.name for p in (tmp_path / "checkpoints").iterdir())
    assert saved == ["epoch_000.ckpt", "last.ckpt"]
    last = torch.load(tmp_path / "checkpoints" / "last.ckpt", map_location="cpu", weights_only=True)
    assert last["epoch"] == 2 and last["global_step"] == 6


class RecordTestWeights(L.Callback):
    """Records the weights the test loop runs on."""

    seen: dict = {}

    def on_test_start(self, trainer, pl_module) -> None:
        RecordTestWeights.seen = {k: v.detach().clone() for k, v in pl_module.state_dict().items()}


def test_weight_ema_is_what_checkpoints_hold_and_the_test_runs_on(tiny_root: Path, tmp_path: Path):
    """With callbacks=ema, the best checkpoint's state_dict is the average (the training weights aside under
    current_model_state), and the test loop runs on exactly those weights."""
    record = ["+callbacks.record._target_=test_train_run.RecordTestWeights"]
    cfg = compose_config("train", tiny_overrides(
        tiny_root, "callbacks=ema", "callbacks.ema.decay=0.5", "trainer.max_epochs=2", "data.batch_size=3",
        *record), tmp_path)
    train(cfg)
    (best,) = [p for p in (tmp_path / "checkpoints").glob("epoch_*.ckpt")]
    saved = torch.load(best, map_location="cpu", weights_only=True)
    average, current = saved["state_dict"], saved["current_model_state"]
    assert not torch.equal(average["net.fc.weight"], current["net.fc.weight"])
    assert RecordTestWeights.seen.keys() == average.keys()
    for name, value in average.items():
        assert torch.equal(RecordTestWeights.seen[name], value), name


def test_ddp_sim_trains_with_two_cpu_processes(tiny_root: Path, tmp_path: Path):
    cfg = compose_config("train", tiny_overrides(tiny_root, "trainer=ddp_sim", "logger=csv"), tmp_path)
    metrics, objects = train(cfg)
    trainer = objects["trainer"]
    assert trainer.world_size == 2 and trainer.strategy.__class__.__name__ == "DDPStrategy"
    assert (tmp_path / "checkpoints" / "last.ckpt").is_file()
    assert "test/acc" in metrics
    # the test split is gathered from both processes: every image once
    assert pd.read_csv(tmp_path / "table1" / "predictions.csv")["image"].nunique() == 3


def test_multirun_sweeps_runs_past_a_failed_job_and_lists_it(tiny_root: Path, tmp_path: Path):
    """A sweep of three learning rates, the second one bad: the other two train and write Table 1, the bad one's
    folder records its one line, and the sweep ends listing it with exit code 1."""
    sweep_dir = tmp_path / "sweep"
    result = run_cli(
        "-m", "vehloc.train.train", "-m", *tiny_overrides(tiny_root, "debug=fdr"),
        "model.optimizer.lr_head=0.01,-1,0.02", f"hydra.sweep.dir={sweep_dir}", cwd=tmp_path,
    )
    assert result.returncode == 1, result.stderr[-3000:]
    for job in ("0", "2"):
        assert (sweep_dir / job / "table1" / "report.md").is_file()
    overrides = [(sweep_dir / job / ".hydra" / "overrides.yaml").read_text() for job in ("0", "1", "2")]
    assert "lr_head=0.01" in overrides[0] and "lr_head=-1" in overrides[1] and "lr_head=0.02" in overrides[2]
    recorded = (sweep_dir / "1" / "job_error.txt").read_text()
    assert "lr_head" in recorded and not (sweep_dir / "1" / "table1").exists()
    summary = error_lines(result.stderr, "vehloc-train")[-1]
    assert summary.startswith("vehloc-train: error: 1 of 3 jobs failed")
    assert f"model.optimizer.lr_head=-1): {recorded.strip()}" in result.stderr
    assert "Traceback" not in result.stderr
