"""`vehloc-demo` end to end on tiny settings: one run writes both tables and the report; a second skips every
step; a changed training setting redoes training and what follows it; a failed step is named and leaves the
steps before it done; bad settings are refused before any work."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from bad_input import HEAVY_MODULES, assert_one_error, run_cli, run_cli_noting_imports

pytestmark = pytest.mark.slow  # a demo set, one training epoch, an export and one Table 2 scene

TINY = ["data.per_model=4", "data.workers=1", "scenes=[table2_plate_close_0]"]
TRAIN = 'train_overrides=["trainer.max_epochs=1","data.input_size_px=32","data.eval_resize_px=32","logger=[]"]'


def _demo(out: Path, *overrides: str):
    return run_cli("vehloc-demo", f"out={out}", *TINY, *overrides, cwd=out.parent)


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("demo") / "run"
    return out, _demo(out, TRAIN)


def test_the_demo_writes_both_tables_and_the_report(demo_run: tuple[Path, object]) -> None:
    out, done = demo_run
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-1].endswith(str(out / "report.md"))
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "## Table 1" in report and "| 9 | Honda Spirior |" in report
    table2 = pd.read_csv(out / "table2" / "table2.csv")
    assert list(table2["method"]) == ["paper", "fit"] and set(table2["scene"]) == {"table2_plate_close_0"}
    assert "| table2_plate_close_0 | paper | plate |" in report
    assert (out / "summary.png").stat().st_size > 10_000 and (out / "model.onnx").is_file()


def test_a_second_run_skips_every_step_and_a_changed_setting_redoes_what_follows(demo_run: tuple[Path, object]) -> None:
    out, first = demo_run
    assert first.returncode == 0
    model_bytes = (out / "model.onnx").read_bytes()
    again = _demo(out, TRAIN)
    assert again.returncode == 0, again.stderr[-2000:]
    skipped = [line for line in again.stdout.splitlines() if line.endswith("skipped (force=true redoes it)")]
    assert len(skipped) == 5  # data, train, export, the scene, its localization
    assert (out / "model.onnx").read_bytes() == model_bytes
    changed = _demo(out, TRAIN.replace("max_epochs=1", "max_epochs=2"))
    assert changed.returncode == 0, changed.stderr[-2000:]
    redone = [line.split(":")[0] for line in changed.stdout.splitlines() if line.startswith("[demo]") and line.endswith(" s")]
    assert redone[:3] == ["[demo] train", "[demo] export", "[demo] localize_table2_plate_close_0"]
    assert "[demo] data: done before, skipped (force=true redoes it)" in changed.stdout


def test_a_failed_step_is_named_and_the_steps_before_it_stay_done(tmp_path: Path) -> None:
    out, weights = tmp_path / "run", tmp_path / "weights.pth"
    weights.write_bytes(b"not a state dict")  # passes the settings' check, fails when training loads it
    failed = _demo(out, f'train_overrides=["trainer.max_epochs=1","model.backbone.pretrained={weights}"]')
    assert_one_error(failed, "vehloc-demo", "step train failed")
    assert (out / ".steps" / "data.json").is_file() and not (out / ".steps" / "train.json").exists()


@pytest.mark.parametrize("overrides, message", [
    (["data.views=sideways"], "data.views: expected one of any, traffic, road, got 'sideways'"),
    (["scenes=[table2_nowhere]"], "scenes: expected some of table2_middle_0"),
    (['train_overrides=["trainer.max_epochs=-1"]'], "train_overrides"),
    (['train_overrides=["no_such_key=1"]'], "train_overrides"),
    (["train_experiment=no_such_recipe"], "train_experiment: "),
])
def test_bad_settings_are_refused_before_any_work(overrides: list[str], message: str, tmp_path: Path) -> None:
    """Refused before the work's modules load: no torch, Lightning, onnx, pandas or matplotlib."""
    out = tmp_path / "run"
    refused, loaded = run_cli_noting_imports("vehloc-demo", f"out={out}", *TINY, *overrides, cwd=out.parent,
                                             modules=(*HEAVY_MODULES, "pandas", "matplotlib"))
    assert_one_error(refused, "vehloc-demo", message)
    assert not (out / "compcars").exists() and loaded == ""


def test_a_train_folder_the_demo_did_not_make_is_never_removed(tmp_path: Path) -> None:
    """`vehloc-demo` removed an `out/train` folder it did not make (with out='' the current folder's `train/`); it
    removes only one that holds its mark or its train step's stamp, and refuses in one line otherwise."""
    out = tmp_path / "run"
    mine = out / "train" / "notes.txt"
    mine.parent.mkdir(parents=True)
    mine.write_text("a user's own work")
    refused = _demo(out, 'train_overrides=["trainer.max_epochs=1"]')
    assert_one_error(refused, "vehloc-demo", f"{out / 'train'} exists and was not made by vehloc-demo")
    assert mine.read_text() == "a user's own work" and sorted(p.name for p in mine.parent.iterdir()) == ["notes.txt"]
