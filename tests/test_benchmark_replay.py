"""Replaying the paper's key points (or whole stop records) on a benchmark run's captured inputs: a capture folder that is missing, empty,
unreadable or of another version is one error naming it; a case without a stop record keeps its row. (That a replay
with the run's own settings gives every case's paper estimate, and with `refit` its whole record, to the digit, and
that a changed setting moves the cases it should and no other, is checked on the 24-case subset in
`tests/test_benchmark.py`.)"""

from __future__ import annotations

import pickle
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from test_benchmark import PROJECT_ROOT, composed

from vehloc.benchmark.cases import draw_case
from vehloc.benchmark.replay import (
    CAPTURE_FORMAT, CapturedCase, capture_path, read_captures, replayed_row, write_capture,
)
from vehloc.benchmark.suite import BenchmarkSettings
from vehloc.errors import DataError
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.synth.road import RoadLayout


@pytest.fixture(scope="module")
def captured() -> CapturedCase:
    """Dev seed 3 as a run without a stop record leaves it (its row names the reason; no inputs)."""
    settings = BenchmarkSettings.from_config(composed("split=dev"))
    case = draw_case(3, settings.cameras, RoadLayout(**settings.site["layout"]), settings.draw)
    row = {"split": "dev", "seed": 3, "status": "not_localized", "reason_code": "not_tracked_to_stop",
           "localized": False, "key_point": ""}
    return CapturedCase("dev", case, row, None)


def test_a_missing_capture_folder_is_named(tmp_path: Path):
    with pytest.raises(DataError, match="none: no such folder"):
        read_captures(tmp_path / "none")


def test_a_folder_without_captures_is_named(tmp_path: Path):
    with pytest.raises(DataError, match="holds no capture"):
        read_captures(tmp_path)


def test_a_capture_that_is_not_one_is_named(tmp_path: Path):
    (tmp_path / "dev_7.pkl").write_bytes(b"not a pickle")
    with pytest.raises(DataError, match=r"dev_7\.pkl: not a benchmark capture"):
        read_captures(tmp_path)


def test_a_capture_of_another_version_is_refused(tmp_path: Path, captured: CapturedCase):
    capture_path(tmp_path, "dev", 3).write_bytes(pickle.dumps((CAPTURE_FORMAT + 1, captured)))
    with pytest.raises(DataError, match="not a capture of this version"):
        read_captures(tmp_path)


def test_a_written_capture_reads_back_in_seed_order(tmp_path: Path, captured: CapturedCase):
    write_capture(tmp_path, CapturedCase("dev", replace(captured.case, seed=12), captured.row | {"seed": 12}, None))
    write_capture(tmp_path, captured)
    read = read_captures(tmp_path)
    assert [c.case.seed for c in read] == [3, 12]
    assert read[0].row == captured.row
    assert [p.name for p in sorted(tmp_path.iterdir())] == ["dev_12.pkl", "dev_3.pkl"]  # no temporary left


@pytest.mark.parametrize("refit", [False, True])
def test_a_case_without_a_stop_record_keeps_its_row(captured: CapturedCase, refit: bool):
    row = replayed_row(captured, LocalizeSettings.compose(), refit)
    assert row == captured.row and row is not captured.row


def test_the_script_refuses_a_missing_capture_in_one_line(tmp_path: Path):
    script = PROJECT_ROOT / "experiments" / "localization_benchmark" / "replay.py"
    run = subprocess.run([sys.executable, str(script), f"capture={tmp_path / 'none'}", f"out={tmp_path / 'run'}"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    assert run.stderr.strip().splitlines() == [
        f"experiments/localization_benchmark/replay.py: error: {tmp_path / 'none'}: no such folder "
        f"(a benchmark run's capture=DIR)"]
    assert not (tmp_path / "run" / "cases.csv").exists()


@pytest.mark.parametrize(("override", "message"), [("refit=3", "refit: must be true or false, got 3"),
                                                    ("workers=0", "workers: must be a whole number >= 1, got 0")])
def test_the_script_refuses_a_bad_setting_before_reading_the_capture(tmp_path: Path, override: str, message: str):
    script = PROJECT_ROOT / "experiments" / "localization_benchmark" / "replay.py"
    run = subprocess.run([sys.executable, str(script), f"capture={tmp_path / 'none'}", f"out={tmp_path / 'run'}",
                          override], capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    assert run.stderr.strip().splitlines() == [f"experiments/localization_benchmark/replay.py: error: {message}"]
    assert not (tmp_path / "run" / "cases.csv").exists()
