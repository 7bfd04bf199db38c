"""One settings path for the localization: `conf/localize/localize.yaml` composed as `vehloc-localize` composes it
gives the library's defaults, a site's experiment (`experiment=highway`) changes exactly its settings, and a bad
override or setting is one line and exit code 1 from the CLI, before any file is read."""

from __future__ import annotations

import copy
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from bad_input import assert_one_error, side_by_side

from vehloc.config import ConfigError, read_config
from vehloc.geometry.keypoints import DetectorParams
from vehloc.geometry.model_fit import FitParams
from vehloc.geometry.pipeline.settings import STAGE_GROUPS, LocalizeSettings, PipelineParams
from vehloc.geometry.pipeline.track_speed import SpeedParams
from vehloc.geometry.pipeline.tracker import TrackerParams
from vehloc.geometry.roi import RoiParams


def test_the_composed_defaults_are_each_groups_defaults() -> None:
    assert LocalizeSettings.compose() == LocalizeSettings(PipelineParams.from_config(), RoiParams.from_config(),
                                                          TrackerParams.from_config(), DetectorParams.from_config(),
                                                          FitParams.from_config(), SpeedParams.from_config())


def test_the_highway_experiment_sets_its_settings_and_no_other() -> None:
    default, highway = LocalizeSettings.compose(), LocalizeSettings.compose(["experiment=highway"])
    assert highway.pipeline == PipelineParams.from_config(every_frame=True, fit_from_travel=True)
    assert highway.roi == RoiParams.from_config(scale=1.0, close_kernel_px=5, min_area_fraction=0.002)
    assert highway.detectors.wheels == replace(default.detectors.wheels, spoked_rims=False)
    assert replace(highway.detectors, wheels=default.detectors.wheels) == default.detectors
    assert highway.tracker == replace(default.tracker, stop_flicker_frames=0) and highway.fit == default.fit
    assert default.tracker.stop_flicker_frames == 3 and default.pipeline.every_frame is False
    assert default.roi.min_area_fraction == 0.001


def test_the_traffic_experiment_votes_on_the_largest_views_and_changes_nothing_else() -> None:
    default, traffic = LocalizeSettings.compose(), LocalizeSettings.compose(["experiment=traffic"])
    assert default.pipeline.vote_policy == "spread"
    assert traffic.pipeline == PipelineParams.from_config(vote_policy="largest")
    # merged blobs: the other vehicle hidden in the one box, not shared
    assert (default.tracker.motion_frames, default.tracker.max_hidden_frames, default.tracker.max_shared_frames) == (
        5, 50, 0)
    assert (traffic.roi, traffic.tracker, traffic.detectors, traffic.fit, traffic.speed) == (
        default.roi, default.tracker, default.detectors, default.fit, default.speed)


@pytest.mark.parametrize(("overrides", "fragment"), [
    (["roi.nope=1"], "roi.nope"),
    (["experiment=nope"], "experiment/nope"),
    (["pipeline.min_fit_iou=abc"], "pipeline.min_fit_iou"),
    (["tracker.max_lost_frames=0"], "tracker.max_lost_frames"),
])
def test_a_bad_override_of_the_library_is_a_config_error(overrides: list[str], fragment: str) -> None:
    with pytest.raises(ConfigError, match=fragment.replace(".", r"\.")) as caught:
        LocalizeSettings.compose(overrides)
    assert "\n" not in str(caught.value)


def _numeric_settings(values: dict, prefix: str) -> list[tuple[str, object]]:
    """(dotted name, value) of every number or list of numbers in a group's defaults, nested sections included."""
    found = []
    for key, value in values.items():
        name = f"{prefix}.{key}"
        if isinstance(value, dict):
            found += _numeric_settings(value, name)
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            found.append((name, value))
        elif isinstance(value, list) and value and all(isinstance(v, (int, float)) for v in value):
            found.append((name, value))
    return found


NUMERIC_SETTINGS = [setting for group in STAGE_GROUPS
                    for setting in _numeric_settings(read_config(f"localize/{group}/default.yaml"), group)]
SIGNED_OUT_OF_RANGE = {"speed.edge_inset_px": 5.0, "pipeline.silhouette_search_mm": [3000.0, -1500.0, 250.0],
                       "roi.shadow_min_correlation": 2.0, "roi.silhouette_shadow_min_correlation": 2.0,
                       "roi.silhouette_covered_max_correlation": 2.0}
"""The settings where a negative value means something: a value out of their range instead."""


@pytest.fixture(scope="module")
def default_values() -> dict:
    """Each stage group's defaults (plain data), read once."""
    return {group: read_config(f"localize/{group}/default.yaml") for group in STAGE_GROUPS}


@pytest.mark.parametrize("setting", [name for name, _ in NUMERIC_SETTINGS])
def test_every_numeric_setting_of_every_stage_has_its_range_checked(setting: str, default_values: dict) -> None:
    """Each stage's schema checks every number before any frame is read: a negative one (or, where negatives mean
    something, one out of range) is a ConfigError naming the setting, not a traceback, a hang or a silent run. (The
    schema is what a composed override reaches: `test_a_bad_override_of_the_library_is_a_config_error` goes through
    Hydra's composition.)"""
    default = dict(NUMERIC_SETTINGS)[setting]
    bad = SIGNED_OUT_OF_RANGE.get(setting, [-1] * len(default) if isinstance(default, list) else -1)
    values = copy.deepcopy(default_values)
    *path, key = setting.split(".")
    node = values
    for part in path:
        node = node[part]
    node[key] = bad
    with pytest.raises(ConfigError, match=setting.replace(".", r"\.")) as caught:
        LocalizeSettings.from_mapping(values)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(("override", "message"), [
    ("roi.scale=50", "roi.scale: must be in (0, 1], got 50.0"),          # was a segmentation fault after 9 GB
    ("fit.supersample=64", "fit.supersample: must be in [1, 8], got 64"),  # was a hang
    ("roi.close_kernel_px=0", "roi.close_kernel_px: must be in [1, 101], got 0"),
    ("plate.hue_range=[90,10]", "plate.hue_range[1]: must be in [90, 180], got 10"),
    ("wheels.dark_percentile=101", "wheels.dark_percentile: must be in [0, 100], got 101.0"),
])
def test_the_settings_that_crashed_or_hung_are_refused_in_one_line(override: str, message: str) -> None:
    with pytest.raises(ConfigError) as caught:
        LocalizeSettings.compose([override])
    assert str(caught.value) == message


CLI_CASES = {
    "not_a_number": (["pipeline.min_fit_iou=abc"], "pipeline.min_fit_iou"),
    "unknown_key": (["roi.nope=1"], "roi.nope"),
    "no_frames": (["max_frames=0"], "max_frames"),
    "never_lost": (["tracker.max_lost_frames=0"], "tracker.max_lost_frames"),
    "no_fps": (["fps=0"], "fps"),
    "speed_reference": (["speed.reference=wheels"], "speed.reference"),
    "unknown_experiment": (["experiment=nope"], "experiment/nope"),
    "no_video": (["calibration=c.json", "model=m.onnx"], "video=PATH is required"),
    "run_dir_is_a_file": (["hydra.run.dir=file.txt"], "file.txt: exists and is not a folder"),
    "scale_50": (["roi.scale=50"], "roi.scale: must be in (0, 1], got 50.0"),
}


@pytest.fixture(scope="module")
def cli_results(tmp_path_factory: pytest.TempPathFactory) -> dict:
    folder = tmp_path_factory.mktemp("localize_settings")
    (folder / "file.txt").write_text("not a folder")
    base = ["video=missing.avi", "calibration=missing.json", "model=missing.onnx", f"hydra.run.dir={folder / 'run'}"]
    runs = {name: ("vehloc-localize", (base if name != "no_video" else base[3:]) + overrides, folder)
            for name, (overrides, _) in CLI_CASES.items()}
    with side_by_side(runs) as futures:
        return {name: future.result() for name, future in futures.items()}


@pytest.mark.parametrize("case", sorted(CLI_CASES))
def test_a_bad_override_of_the_cli_is_one_line(case: str, cli_results: dict) -> None:
    assert_one_error(cli_results[case], "vehloc-localize", CLI_CASES[case][1])


def test_the_settings_compose_inside_a_hydra_app(tmp_path: Path) -> None:
    """Within a running Hydra app (as `vehloc-demo` localizes its Table 2 scenes), composing the localization's
    settings leaves the app's Hydra as it was."""
    app = tmp_path / "app.py"
    app.write_text(
        "import hydra\n"
        "from hydra.core.global_hydra import GlobalHydra\n"
        "from hydra.core.hydra_config import HydraConfig\n"
        "from vehloc.geometry.pipeline.settings import LocalizeSettings\n"
        "@hydra.main(version_base='1.3', config_path=None)\n"
        "def main(cfg):\n"
        "    before = HydraConfig.get().runtime.output_dir\n"
        "    settings = LocalizeSettings.compose(['experiment=highway'])\n"
        "    assert GlobalHydra.instance().is_initialized() and HydraConfig.get().runtime.output_dir == before\n"
        "    print(settings.roi.min_area_fraction)\n"
        "main()\n")
    run = subprocess.run([sys.executable, str(app), f"hydra.run.dir={tmp_path / 'run'}"], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "0.002"
