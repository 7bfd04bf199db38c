"""`vehloc-data check` on the real set, and on a broken copy of it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from vehloc.synth.cli import main


def test_check_real_set_is_clean(stanford_root: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(stanford_root)]) == 0
    out = capsys.readouterr().out
    assert "classes: 12" in out and "train: 366 images" in out and "test: 138 images" in out
    assert "covers all 12 classes" in out and "no problems found" in out


def test_check_broken_copy_names_both_files(stanford_copy: Path) -> None:
    deleted = stanford_copy / "image/1/1/2012/00070.jpg"
    truncated = stanford_copy / "label/3/3/2012/06582.txt"
    deleted.unlink()
    truncated.write_text(truncated.read_text()[:5])
    run = subprocess.run(
        [sys.executable, "-m", "vehloc.synth.cli", "check", str(stanford_copy)],
        capture_output=True, text=True,
    )
    assert run.returncode == 1
    assert f"image {deleted} missing" in run.stderr
    assert f"{truncated}: malformed label" in run.stderr
    assert "2 problem(s)" in run.stderr


def test_check_specs_lacking_a_class(stanford_copy: Path, capsys: pytest.CaptureFixture[str]) -> None:
    specs = stanford_copy / "specs.csv"
    specs.write_text("".join(line for line in specs.open() if not line.startswith("7,")))
    assert main(["check", str(stanford_copy)]) == 1
    err = capsys.readouterr().err
    assert "no dimensions for 1 class(es)" in err and "model 7 (Mercedes-Benz C-Class Sedan)" in err


def test_check_missing_root(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", str(tmp_path / "absent")]) == 1
    assert "data root does not exist" in capsys.readouterr().err
