"""The speed benchmark's script: the seeds it is asked for, and each split's cases pooled by the scorer's counts
(recall over the valid true cars, precision over the reported cars, the matched cars' errors together)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "experiments" / "speed" / "run.py"


@pytest.fixture(scope="module")
def speed_run():
    spec = importlib.util.spec_from_file_location("speed_run", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


def test_cases_are_ranges_or_single_seeds(speed_run) -> None:
    assert speed_run.parse_cases(["traffic_720p:107-109", "traffic_240p:5"]) == [
        ("traffic_720p", 107), ("traffic_720p", 108), ("traffic_720p", 109), ("traffic_240p", 5)]
    with pytest.raises(ValueError, match="traffic_720p:9-8"):
        speed_run.parse_cases(["traffic_720p:9-8"])
    with pytest.raises(ValueError, match="expected SCENE:SEED"):
        speed_run.parse_cases(["traffic_720p"])


def _case(folder: Path, matches: list[tuple[bool, float | None, int | None]]) -> None:
    """A case's score folder: per true car whether it is valid, its matched speed error (km/h), the matched car."""
    (folder / "score").mkdir(parents=True)
    rows = [{"truth_id": i, "lane": 0, "valid": valid, "last_time_s": float(i), "true_speed_kmh": 80.0,
             "car_id": car, "speed_kmh": None if error is None else 80.0 + error, "error_kmh": error}
            for i, (valid, error, car) in enumerate(matches)]
    pd.DataFrame(rows).to_csv(folder / "score" / "matches.csv", index=False)


def test_pooled_counts_cars_over_the_cases(speed_run, tmp_path: Path) -> None:
    """Two cases: 3 of 4 valid true cars found in the first (its invalid one counts for precision only), 2 of 3 in
    the second; 4 and 2 reported cars matched against 1 and 3 false positives: recall 5/7, precision 6/10, the five
    valid cars' errors pooled."""
    _case(tmp_path / "a", [(True, 0.5, 1), (True, -1.0, 2), (True, None, None), (False, 4.0, 3), (True, 0.2, 4)])
    _case(tmp_path / "b", [(True, 2.0, 7), (True, None, None), (True, -0.1, 8)])
    table = pd.DataFrame([
        {"case": "a", "scene": "traffic_720p", "split": "heldout", "classifier": "m", "recall": 0.75,
         "precision": 0.8, "true_cars": 4, "false_positives": 1, "median_error_kmh": 0.5, "mean_error_kmh": 0.57,
         "p95_error_kmh": 0.95, "worst_error_kmh": 1.0},
        {"case": "b", "scene": "traffic_720p", "split": "heldout", "classifier": "m", "recall": 2 / 3,
         "precision": 0.4, "true_cars": 3, "false_positives": 3, "median_error_kmh": 1.05, "mean_error_kmh": 1.05,
         "p95_error_kmh": 1.9, "worst_error_kmh": 2.0}])
    pooled = speed_run.pooled(table, {"a": tmp_path / "a", "b": tmp_path / "b"}).iloc[0]
    errors = np.array([0.5, 1.0, 0.2, 2.0, 0.1])
    assert pooled["cases"] == 2 and pooled["true_cars"] == 7
    assert pooled["recall"] == pytest.approx(5 / 7)
    assert pooled["precision"] == pytest.approx(6 / 10)
    assert pooled["mean_error_kmh"] == pytest.approx(errors.mean())
    assert pooled["median_error_kmh"] == pytest.approx(0.5)
    assert pooled["p95_error_kmh"] == pytest.approx(np.percentile(errors, 95))
    assert pooled["worst_error_kmh"] == pytest.approx(2.0)
    assert pooled["cases_meeting_every_bar"] == 0  # recall below 95 % in both
