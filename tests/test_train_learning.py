"""Learning end to end on CPU (slow): GoogLeNet from scratch on the demo set, and the ImageNet
EfficientNet-Lite0 fine-tuned on the real 12-model Stanford Cars subset."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from vehloc.train.instantiate import compose_config
from vehloc.train.train import train

PROJECT_ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_demo_experiment_reaches_90_percent(tmp_path: Path):
    """GoogLeNet from scratch on the demo set of `make demo` (chance: 8.3 % top-1, 41.7 % top-5), the best
    epoch picked on a validation share of train, scored on the unseen test split."""
    from vehloc.synth.demo_set import make_demo_set

    root = make_demo_set(tmp_path / "demo", per_model=240, seed=0, workers=2)
    cfg = compose_config("train", ["experiment=demo", f"data.root={root}"], tmp_path / "run")
    metrics, _ = train(cfg)
    assert metrics["test/acc"] >= 0.90 and metrics["test/acc_top5"] >= 0.98
    table1 = pd.read_csv(tmp_path / "run" / "table1" / "table1.csv")
    assert len(table1) == 12 and table1["images"].sum() == 720


@pytest.mark.slow
def test_stanford_cars_12_fine_tunes_far_above_chance(stanford_root: Path, tmp_path: Path):
    cfg = compose_config("train", ["experiment=stanford_cars_12", f"paths.root_dir={PROJECT_ROOT}"], tmp_path)
    assert Path(cfg.data.root).resolve() == stanford_root.resolve()
    metrics, _ = train(cfg)
    assert metrics["test/acc"] >= 0.5  # chance: 1/12
    assert metrics["test/acc_top5"] >= 0.85
    table1 = pd.read_csv(tmp_path / "table1" / "table1.csv")
    assert len(table1) == 12 and table1["images"].sum() == 138
