"""`vehloc-eval`: Table 1 from a checkpoint, the same numbers as the test at the end of training, and
bad input (no checkpoint, another class count) as one clear line with a non-zero exit."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import torch
from conftest import write_tiny_compcars

from vehloc.train.checkpoints import chosen_on_test_split
from vehloc.train.evaluate import evaluate
from vehloc.train.instantiate import compose_config
from vehloc.train.train import train

SMALL = ["data.input_size_px=32", "data.eval_resize_px=32", "data.num_workers=0"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A tiny root and a 1-epoch run on it: its best checkpoint and end-of-training test metrics."""
    base = tmp_path_factory.mktemp("eval")
    root = write_tiny_compcars(base / "tiny")
    run = base / "run"
    cfg = compose_config("train", [f"data.root={root}", "data.batch_size=4", "model.backbone.pretrained=none",
                                   "trainer.max_epochs=1", *SMALL], run)
    metrics, objects = train(cfg)
    best = Path(objects["trainer"].checkpoint_callback.best_model_path)
    return {"root": root, "run": run, "metrics": metrics, "best": best}


def test_a_checkpoint_says_whether_its_run_chose_it_on_the_test_split():
    assert chosen_on_test_split({"datamodule_hyper_parameters": {"val_fraction": 0.0, "select_on_test": True}})
    assert not chosen_on_test_split({"datamodule_hyper_parameters": {"val_fraction": 0.1, "select_on_test": False}})
    assert chosen_on_test_split({"datamodule_hyper_parameters": {"val_fraction": 0.0}})  # written before the setting
    assert not chosen_on_test_split({})


def run_eval(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, "-m", "vehloc.train.evaluate", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_checkpoints_load_weights_only_and_carry_the_class_table(trained: dict):
    checkpoint = torch.load(trained["best"], map_location="cpu", weights_only=True)
    hparams = checkpoint["hyper_parameters"]
    assert hparams["class_model_ids"] == [11, 12, 25]
    assert hparams["class_makes"] == ["MakeOne", "MakeOne", "MakeTwo"]
    assert hparams["class_models"] == ["Alpha", "Beta", "Gamma"]
    assert hparams["class_dims_mm"][2] == [4000.0, 1700.0, 1600.0]
    assert (hparams["input_size_px"], hparams["eval_resize_px"], hparams["roi_enlarge_fraction"]) == (32, 32, 0.1)
    assert (trained["run"] / "checkpoints" / "last.ckpt").is_file()


def test_eval_reproduces_the_end_of_training_test_and_writes_table1(trained: dict, tmp_path: Path):
    cfg = compose_config("eval", [f"data.root={trained['root']}", f"ckpt_path={trained['best']}", *SMALL], tmp_path)
    metrics, _ = evaluate(cfg)
    for key in ("test/acc", "test/acc_top5", "test/dim_err_pct", "test/dim_err_pct_expected"):
        assert metrics[key] == pytest.approx(trained["metrics"][key], abs=1e-6)
    table1 = pd.read_csv(tmp_path / "table1" / "table1.csv")
    assert table1["model"].tolist() == ["MakeOne Alpha", "MakeOne Beta", "MakeTwo Gamma"]
    accuracy = pd.read_csv(tmp_path / "table1" / "accuracy.csv").set_index("metric")["value"]
    assert accuracy["top1_pct"] == pytest.approx(100 * metrics["test/acc"], abs=1e-3)
    assert (tmp_path / "table1" / "report.md").read_text().startswith("# Evaluation")


def test_eval_cli_writes_into_its_run_folder(trained: dict, tmp_path: Path):
    out = tmp_path / "evalrun"
    result = run_eval(f"data.root={trained['root']}", f"ckpt_path={trained['best']}", f"hydra.run.dir={out}",
                      *SMALL, cwd=tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert {p.name for p in (out / "table1").iterdir()} >= {"table1.csv", "report.md", "confusion_matrix.png"}
    assert (out / ".hydra" / "config.yaml").is_file()


def test_checkpoint_of_another_class_count_is_refused_and_left_intact(trained: dict, tmp_path: Path):
    two = write_tiny_compcars(tmp_path / "two")
    split_dir = two / "train_test_split" / "classification"
    for split in ("train", "test"):
        path = split_dir / f"{split}.txt"
        path.write_text("".join(line + "\n" for line in path.read_text().split() if "/25/" not in line))
    digest = hashlib.sha256(trained["best"].read_bytes()).hexdigest()
    result = run_eval(f"data.root={two}", f"ckpt_path={trained['best']}", f"hydra.run.dir={tmp_path / 'out'}",
                      cwd=tmp_path)
    assert result.returncode == 1
    lines = [line for line in result.stderr.splitlines() if line.startswith("vehloc-eval: error:")]
    assert len(lines) == 1 and "checkpoint has 3 classes" in lines[0] and "has 2 (model ids" in lines[0]
    assert "Traceback" not in result.stderr
    assert hashlib.sha256(trained["best"].read_bytes()).hexdigest() == digest

    resume = subprocess.run(
        [sys.executable, "-m", "vehloc.train.train", f"data.root={two}", f"ckpt_path={trained['best']}",
         f"hydra.run.dir={tmp_path / 'resume'}", "model.backbone.pretrained=none", *SMALL],
        cwd=tmp_path, capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONWARNINGS": "ignore"},
    )
    assert resume.returncode == 1 and "checkpoint has 3 classes" in resume.stderr
    assert not list((tmp_path / "resume").rglob("*.ckpt"))


def test_eval_without_a_checkpoint_says_so(tmp_path: Path):
    result = run_eval(f"hydra.run.dir={tmp_path / 'out'}", cwd=tmp_path)
    assert result.returncode == 1
    assert "vehloc-eval: error: ckpt_path=PATH is required" in result.stderr
    result = run_eval(f"ckpt_path={tmp_path / 'nothing.ckpt'}", f"hydra.run.dir={tmp_path / 'out'}", cwd=tmp_path)
    assert result.returncode == 1 and "nothing.ckpt: no such checkpoint file" in result.stderr
