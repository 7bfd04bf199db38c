"""Two benchmark runs compared case by case: the exact sign (McNemar) test, the gates' gains and losses and the
changed cases against runs built with known differences, and the comparison script refusing runs that are not of
the same cases in one line, writing nothing."""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binomtest

from vehloc.benchmark.paired import MOVE_TOLERANCE, POOLED, compare_runs, read_cases, sign_test_p
from vehloc.errors import DataError

SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "localization_benchmark" / "compare.py"
SEEDS = 40


def run_frame(seed0: int = 0, cases: int = SEEDS) -> pd.DataFrame:
    """A run's cases as `cases.csv` holds them: every case localized, its fit within, key points visible on the
    even seeds and found and within there."""
    seeds = np.arange(seed0, seed0 + cases)
    even = seeds % 2 == 0
    return pd.DataFrame({
        "split": "dev", "seed": seeds, "model": "Honda Spirior", "status": "localized",
        "key_point": np.where(even, "plate", ""), "model_id": seeds % 7, "camera_name": "table2",
        "x_mm": 100.0 * seeds, "y_mm": 20000.0 + seeds, "heading_deg": 9.0 * seeds % 360,
        "localized": 1.0, "fit_within": 1.0,
        "key_points_found": np.where(even, 1.0, np.nan), "paper_within": np.where(even, 1.0, np.nan),
        "fit_position_pct": 0.2 + 0.01 * seeds, "fit_heading_deg": 0.1,
        "paper_position_pct": np.where(even, 1.0, np.nan), "paper_heading_deg": np.where(even, 0.5, np.nan)})


@pytest.mark.parametrize("wins", range(0, 13, 3))
@pytest.mark.parametrize("losses", range(0, 13, 4))
def test_the_sign_test_is_the_exact_binomial_test(wins: int, losses: int):
    """Against scipy's exact two-sided binomial test at p = 1/2 (to 1e-12); 1 where nothing changed sides."""
    expected = 1.0 if wins + losses == 0 else binomtest(wins, wins + losses, 0.5).pvalue
    assert sign_test_p(wins, losses) == pytest.approx(expected, abs=1e-12)


def test_five_gains_and_no_loss_is_a_one_in_sixteen_chance():
    assert sign_test_p(5, 0) == sign_test_p(0, 5) == pytest.approx(2 / 2 ** 5, abs=0)
    assert sign_test_p(6, 4) == pytest.approx(2 * sum(math.comb(10, k) for k in range(5)) / 2 ** 10, abs=1e-15)
    with pytest.raises(ValueError, match="counts must be >= 0"):
        sign_test_p(-1, 2)


def test_the_gates_count_what_each_run_gained_and_lost():
    """Seeds 3 and 5 lose the fit, 10 gains the paper's method, 11 leaves the fit's cases (not localized), 20's
    paper error moves and 21's by less than the tolerance: exactly those gains, losses, rates and changed cases."""
    before, after = run_frame(), run_frame()
    before.loc[10, "paper_within"] = 0.0
    after.loc[[3, 5], "fit_within"] = 0.0
    after.loc[[3, 5], "fit_position_pct"] = 1.4
    after.loc[11, ["localized", "fit_within", "status"]] = [0.0, np.nan, "not_localized"]
    after.loc[11, ["fit_position_pct", "fit_heading_deg"]] = np.nan
    after.loc[20, "paper_position_pct"] = 1.5
    after.loc[21, "fit_position_pct"] += MOVE_TOLERANCE / 2
    comparison = compare_runs(read_cases_of(before), read_cases_of(after))
    gates = {g.gate: g for g in comparison.gates}
    assert (gates["fit_within"].lost, gates["fit_within"].gained, gates["fit_within"].cases) == ((3, 5), (), 39)
    assert gates["fit_within"].before_pct == 100.0
    assert gates["fit_within"].after_pct == pytest.approx(100.0 * 37 / 39, abs=1e-12)
    assert gates["fit_within"].p_value == 0.5
    assert (gates["localized"].lost, gates["localized"].after_pct) == ((11,), 97.5)
    assert (gates["paper_within"].gained, gates["paper_within"].before_pct, gates["paper_within"].cases) == ((10,), 95.0, 20)
    assert gates["key_points_found"].gained == gates["key_points_found"].lost == ()
    assert list(comparison.changed["seed"]) == [3, 5, 10, 11, 20]
    assert list(comparison.changed["fit_within"]) == ["lost", "lost", "", "", ""]
    assert comparison.changed.set_index("seed").at[20, "paper_position_pct_after"] == 1.5
    errors = {e.column: e for e in comparison.errors}
    assert (errors["fit_position_pct"].worse, errors["fit_position_pct"].better, errors["fit_position_pct"].cases) == (2, 0, 39)
    assert errors["fit_position_pct"].median_change == pytest.approx(1.4 - 0.24, abs=1e-9)  # 0.23 and 0.25 -> 1.4
    assert np.isnan(errors["fit_heading_deg"].median_change)
    assert (errors["paper_position_pct"].worse, errors["paper_position_pct"].cases) == (1, 20)


def test_the_gains_and_losses_of_several_splits_add_up():
    """A run of both splits: per split and over both, whose gains and losses are the splits' together."""
    before = pd.concat([run_frame(), run_frame(100000).assign(split="heldout")], ignore_index=True)
    after = before.copy()
    after.loc[after["seed"].isin([1, 3, 100001]), "fit_within"] = 0.0
    before.loc[before["seed"].isin([7, 100005, 100007, 100009]), "fit_within"] = 0.0
    fit = {g.split: g for g in compare_runs(read_cases_of(before), read_cases_of(after)).gates if g.gate == "fit_within"}
    assert [(s, len(g.gained), len(g.lost), g.cases) for s, g in fit.items()] == [
        ("dev", 1, 2, 40), ("heldout", 3, 1, 40), (POOLED, 4, 3, 80)]
    assert fit[POOLED].p_value == sign_test_p(4, 3)
    assert fit[POOLED].gained == (7, 100005, 100007, 100009)


def test_each_gate_per_group_before_and_after():
    """A view per case (seeds 0-9 `front`, the rest `side`) and seeds 2 and 4 (front) losing the paper's method,
    13 (side) the fit: per view (and model: one), the group's cases and each gate's rate over its own cases in each
    run, exactly; a column only one run holds gives no groups."""
    before, after = run_frame(), run_frame()
    after.loc[[2, 4], "paper_within"] = 0.0
    after.loc[13, "fit_within"] = 0.0
    for frame in (before, after):
        frame["view"] = np.where(frame["seed"] < 10, "front", "side")
    before["colour_group"] = "grey"
    everything = compare_runs(read_cases_of(before), read_cases_of(after)).groups
    assert list(everything["by"]) == ["view", "view", "model"]  # no colour group: the run after holds none
    groups = everything.set_index("group")
    assert list(groups["cases"]) == [10, 30, 40]
    assert groups.loc["front", "paper_within_before_pct"] == 100.0
    assert groups.loc["front", "paper_within_after_pct"] == pytest.approx(100.0 * 3 / 5, abs=1e-12)
    assert groups.loc["side", "paper_within_after_pct"] == 100.0
    assert groups.loc["side", "fit_within_after_pct"] == pytest.approx(100.0 * 29 / 30, abs=1e-12)
    assert groups.loc["front", "fit_within_after_pct"] == groups.loc["side", "localized_after_pct"] == 100.0


def test_a_run_compared_with_itself_changes_nothing():
    comparison = compare_runs(read_cases_of(run_frame()), read_cases_of(run_frame().iloc[::-1]))
    assert comparison.changed.empty
    assert all(g.gained == g.lost == () and g.p_value == 1.0 and g.before_pct == g.after_pct for g in comparison.gates)


def read_cases_of(frame: pd.DataFrame) -> pd.DataFrame:
    """The frame as `read_cases` gives it back from a written `cases.csv`."""
    with tempfile.TemporaryDirectory() as temporary:
        path = Path(temporary) / "cases.csv"
        frame.to_csv(path, index=False, float_format="%.3f")
        return read_cases(path.parent)


@pytest.mark.parametrize(("change", "message"), [
    (lambda f: f.iloc[:-1], "before.csv: holds 1 seed(s) the other run does not (first 39)"),
    (lambda f: f.assign(seed=f["seed"] + 1), "before.csv: holds 1 seed(s) the other run does not (first 0)"),
    (lambda f: f.assign(heading_deg=f["heading_deg"].where(f["seed"] != 7, 1.0)),
     "after.csv: seed 7 is not the case of before.csv (heading_deg 1.0 against 63.0)"),
    (lambda f: f.assign(camera_name=f["camera_name"].where(f["seed"] != 2, "high_gantry")),
     "after.csv: seed 2 is not the case of before.csv (camera_name high_gantry against table2)"),
])
def test_runs_of_other_cases_are_refused_naming_the_run_and_the_seed(change, message: str):
    with pytest.raises(DataError) as err:
        compare_runs(read_cases_of(run_frame()), read_cases_of(change(run_frame())), ("before.csv", "after.csv"))
    assert str(err.value).startswith(message)


@pytest.mark.parametrize(("write", "message"), [
    (None, "no such file"),
    (lambda p: run_frame().drop(columns=["paper_within", "model_id"]).to_csv(p, index=False),
     "not a benchmark's cases.csv: no column model_id, paper_within"),
    (lambda p: pd.concat([run_frame(), run_frame().iloc[[4]]]).to_csv(p, index=False), "seed 4 is in it twice"),
    (lambda p: p.write_bytes(b""), "not a benchmark's cases.csv"),
])
def test_a_file_that_is_not_a_run_is_named(tmp_path: Path, write, message: str):
    path = tmp_path / "cases.csv"
    if write:
        write(path)
    with pytest.raises(DataError, match=message):
        read_cases(tmp_path)
    assert str(path) in str(pytest.raises(DataError, read_cases, path).value)


def test_the_script_writes_the_comparison(tmp_path: Path):
    before, after = run_frame(), run_frame()
    after.loc[[3, 5, 9], "fit_within"] = 0.0
    for name, frame in (("before", before), ("after", after)):
        (tmp_path / name).mkdir()
        frame.to_csv(tmp_path / name / "cases.csv", index=False)
    out = tmp_path / "compare"
    run = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "before"), str(tmp_path / "after"),
                          "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert {p.name for p in out.iterdir()} == {"gates.csv", "errors.csv", "changed_cases.csv", "groups.csv",
                                               "compare.md", "compare.png"}
    gates = pd.read_csv(out / "gates.csv").set_index("gate")
    fit = gates.loc["model fit within 1 % and 1 deg (correct model)"]
    assert (fit["lost"], fit["gained"], fit["seeds lost"]) == (3, 0, "3, 5, 9")
    assert fit["McNemar p"] == pytest.approx(0.25, abs=1e-4)
    assert list(pd.read_csv(out / "changed_cases.csv")["seed"]) == [3, 5, 9]
    assert "no evidence of a change" in (out / "compare.md").read_text()


def test_the_script_refuses_runs_of_other_seeds_in_one_line_and_writes_nothing(tmp_path: Path):
    for name, seed0 in (("before", 0), ("after", 100000)):
        (tmp_path / name).mkdir()
        run_frame(seed0).to_csv(tmp_path / name / "cases.csv", index=False)
    out = tmp_path / "compare"
    run = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "before"), str(tmp_path / "after"),
                          "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 1
    assert run.stderr.strip().splitlines() == [
        f"experiments/localization_benchmark/compare.py: error: {tmp_path / 'before'}: holds 40 seed(s) the other run "
        "does not (first 0); compare runs of the same split and number of cases"]
    assert not out.exists()
