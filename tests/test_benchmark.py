"""The randomized localization benchmark: its cases are seeded and cover what they claim to; its visibility
truth agrees with the exact geometry; its settings are checked before any case runs; and a 24-case subset of
its development seeds, localized end to end, holds the rates it reached (a regression gate)."""

from __future__ import annotations

import hashlib
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from vehloc.benchmark.cases import COLOUR_GROUPS, colour_group, draw_case, in_view
from vehloc.benchmark.paired import compare_runs, read_cases
from vehloc.benchmark.replay import read_captures, replay
from vehloc.benchmark.report import gate_lines, view_of, wilson_interval_pct, with_groups, write_report
from vehloc.benchmark.runner import STOP_LOOKAHEAD_FRAMES, localize_stopped_car, run_case, true_box
from vehloc.benchmark.suite import BenchmarkSettings, failed_row, run_benchmark, short_reason
from vehloc.benchmark.visibility import VisibilityParams, visibility
from vehloc.config import ConfigError, config_dir
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.geometry.placement import heading_difference_deg
from vehloc.synth.catalog import CATALOG, model_by_id
from vehloc.synth.render import CarPose
from vehloc.synth.road import RoadLayout
from vehloc.synth.scene import CameraSpec, write_video

PROJECT_ROOT = Path(__file__).resolve().parents[1]
GATE_SEEDS = 24
GATE_LOCALIZED, GATE_FIT_WITHIN, GATE_KEY_POINTS = 23, 19, 17
"""The subset reaches 24 localized (23 before a standing car's box could stray for a frame or two: seed 11), 20 fits
within 1 % and 1 deg (19 before the road's shadow was fitted up to the car's outline, 18 before the shadow refit read
the outline where the car meets its shadow, 17 before a coloured
car's shadow was told beside its colour's bleed, 14 before the outline's pixels weighed the share the vehicle covers,
11 before the fit was refitted without the road's shadow) and the paper's key points found on
18 of its 20 cases that show them; one case of each is the margin for another CPU's arithmetic (some fits lie within
0.15 of a bar). Before one wheel placed the box (seed 1,
0.82 % off), key points on 17. Before spoked rims were grouped from their gaps, 12 fits (seed 4's fit, started from
its wheels now, is 1.5 deg off) and key points on 15; before small plates were found by their colour's outline, 12;
before the wheels' axles and the boxes' grid, 22 localized and 11 fits within; before the wheels' last change (the
rim kept over its hub, the ground where the tyre ends) key points on 10; before the wider wheel band and the smaller
blobs 8; before the fit from the silhouette and the covered-road cue, 7 were localized and 5 fits within."""


def composed(*overrides: str) -> dict:
    with initialize_config_dir(version_base="1.3", config_dir=str(config_dir()), job_name="benchmark"):
        return OmegaConf.to_container(compose("localization_benchmark", overrides=list(overrides)), resolve=True)


@pytest.fixture(scope="module")
def settings() -> BenchmarkSettings:
    return BenchmarkSettings.from_config(composed("split=both"))


def test_a_seed_always_draws_the_same_case_and_the_car_stands_in_view(settings: BenchmarkSettings):
    layout = RoadLayout(**settings.site["layout"])
    first = [draw_case(seed, settings.cameras, layout, settings.draw) for seed in range(20)]
    assert first == [draw_case(seed, settings.cameras, layout, settings.draw) for seed in range(20)]
    for case in first:
        assert in_view(settings.cameras[case.camera_name], case.model_id, case.pose, settings.draw.margin_px)
        foot = np.array(settings.cameras[case.camera_name].position_mm[:2])
        assert np.hypot(case.x_mm - foot[0], case.y_mm - foot[1]) == pytest.approx(case.distance_mm, abs=1e-6)


def test_the_development_seeds_cover_every_model_colour_group_camera_and_heading(settings: BenchmarkSettings):
    layout = RoadLayout(**settings.site["layout"])
    cases = [draw_case(seed, settings.cameras, layout, settings.draw) for seed in settings.seeds["dev"]]
    assert {c.model_id for c in cases} == {m.model_id for m in CATALOG}
    assert {c.colour_group for c in cases} == set(COLOUR_GROUPS)
    assert {c.camera_name for c in cases} == set(settings.cameras) and len(settings.cameras) >= 4
    assert {int(c.heading_deg // 45) for c in cases} == set(range(8))
    distances_m = np.array([c.distance_mm for c in cases]) / 1000.0
    assert distances_m.min() < 10.0 and distances_m.max() > 35.0
    assert {c.plates for c in cases} == {True, False}
    assert not set(settings.seeds["dev"]) & set(settings.seeds["heldout"])


@pytest.mark.parametrize(("rgb", "group"), [((250, 250, 250), "white"), ((12, 12, 14), "black"),
                                            ((140, 140, 145), "grey"), ((200, 20, 20), "saturated"),
                                            ((30, 60, 160), "saturated")])
def test_a_paint_falls_in_its_colour_group(rgb: tuple[int, int, int], group: str):
    assert colour_group(rgb) == group


CAMERA = CameraSpec((0.0, -6000.0, 6500.0), (0.0, 9000.0, 0.0), 1000.0, 1280, 720, 0.0)
SEEN = VisibilityParams(plate_min_width_px=14.0, plate_min_facing=0.3, tyre_min_facing=0.4, tyre_min_diameter_px=14.0)


def test_a_car_across_the_road_shows_its_near_tyres_and_no_plate():
    """Heading 0 (front to +X) at X = 0, 10 m up the road: its right side (-Y) faces the camera behind it."""
    seen = visibility(model_by_id(9), CarPose(0.0, 10000.0, 0.0), CAMERA.camera(), True, SEEN)
    assert seen.tyres == (False, True, False, True)  # front-left, front-right, rear-left, rear-right
    assert seen.two_tyres and not seen.plate and seen.key_points


@pytest.mark.parametrize(("heading_deg", "end"), [(90.0, "rear"), (-90.0, "front")])
def test_a_car_along_the_road_shows_the_plate_of_the_end_turned_to_the_camera(heading_deg: float, end: str):
    seen = visibility(model_by_id(9), CarPose(0.0, 10000.0, heading_deg), CAMERA.camera(), True, SEEN)
    assert seen.plate_end == end and not seen.two_tyres
    assert visibility(model_by_id(9), CarPose(0.0, 10000.0, heading_deg), CAMERA.camera(), False, SEEN).plate_end is None


def test_a_far_plate_is_too_small_to_count():
    """440 mm at 60 m through f = 1000 px is about 7 px: below the 14 px the truth asks."""
    assert visibility(model_by_id(9), CarPose(0.0, 54000.0, 90.0), CAMERA.camera(), True, SEEN).plate_end is None


@pytest.mark.parametrize(("heading_deg", "view"), [(-90.0, "front"), (90.0, "rear"), (0.0, "side"),
                                                   (-45.0, "front quarter"), (135.0, "rear quarter")])
def test_the_view_is_the_angle_between_the_front_and_the_camera(heading_deg: float, view: str):
    """A car 16 m straight up the road from the camera's foot: heading -90 deg points its front at the camera."""
    row = pd.Series({"x_mm": 0.0, "y_mm": 10000.0, "camera_x_mm": 0.0, "camera_y_mm": -6000.0,
                     "heading_deg": heading_deg})
    assert view_of(row) == view


@pytest.mark.parametrize("successes, cases", [(158, 199), (0, 24), (24, 24), (5, 10), (1, 2)])
def test_a_gate_rate_carries_the_wilson_interval(successes: int, cases: int):
    """The interval agrees with scipy's Wilson interval within 0.01 points (it takes z = 1.96, scipy the exact
    quantile) and holds the rate."""
    from scipy.stats import binomtest

    expected = binomtest(successes, cases).proportion_ci(0.95, method="wilson")
    low, high = wilson_interval_pct(successes, cases)
    assert low == pytest.approx(100 * expected.low, abs=0.01) and high == pytest.approx(100 * expected.high, abs=0.01)
    assert low <= 100 * successes / cases <= high


def test_the_gate_table_shows_each_rate_with_its_interval():
    """Seven fits within of eight: 87.5 %, its interval 52.9-97.8 % (Wilson, 95 %), below the 95 % bar."""
    frame = pd.DataFrame({"split": ["dev"] * 8, "localized": [True] * 8, "fit_within": [True] * 7 + [False],
                          "key_points_found": [np.nan] * 8, "paper_within": [np.nan] * 8})
    fit_line = next(line for line in gate_lines(frame) if "model fit" in line)
    assert "| 8 | 87.5 % | 52.9-97.8 % | 95 % | no |" in fit_line


def test_a_case_that_raised_is_a_row_and_the_report_is_still_written(settings: BenchmarkSettings, tmp_path: Path):
    """A case whose run raised is a row saying why (its camera and pose kept, so its view is known), and the
    report over it and a localized case is written."""
    case = draw_case(3, settings.cameras, RoadLayout(**settings.site["layout"]), settings.draw)
    row = failed_row(case, "dev", settings.cameras[case.camera_name], ValueError("a bad frame"))
    assert short_reason(row) == "error (ValueError: a bad frame)"
    good = {**row, "status": "localized", "reason": "", "localized": True, "fit_within": True,
            "fit_position_pct": 0.5, "fit_heading_deg": 0.2, "road_mm_per_px": 40.0}
    frame = pd.DataFrame([row, good])
    assert list(with_groups(frame)["view"]) == [view_of(pd.Series(good))] * 2
    written = write_report(frame, tmp_path, "one error", [])
    assert {p.name for p in written} >= {"cases.csv", "groups.csv", "report.md", "errors.png"}
    assert pd.read_csv(tmp_path / "cases.csv")["status"].tolist() == ["error", "localized"]


def test_the_true_box_is_the_footprint_at_the_stop(settings: BenchmarkSettings):
    """Table 2's box from the tyres and the axles' middle is the footprint centred on the car's pose (to 1e-6)."""
    case = draw_case(3, settings.cameras, RoadLayout(**settings.site["layout"]), settings.draw)
    box, model = true_box(case), model_by_id(case.model_id)
    np.testing.assert_allclose(box.centre_mm, [case.x_mm, case.y_mm], atol=1e-6)
    assert heading_difference_deg(box.heading_deg, case.heading_deg) == pytest.approx(0.0, abs=1e-6)
    assert (box.length_mm, box.width_mm) == (model.length_mm, model.width_mm)


@pytest.mark.parametrize(("override", "message"), [
    ("split=train", "split: must be dev, heldout or both"),
    ("cases=0", "cases: must be a whole number >= 1"),
    ("draw.plate_probability=1.5", "draw.plate_probability"),
    ("cameras.low_verge.focal_px=-3", "cameras.low_verge.focal_px"),
    ("visibility.tyre_min_diameter_px=-1", "visibility.tyre_min_diameter_px"),
    ("draw.margin_px=-2", "draw.margin_px"),
    ("localize.roi.silhouette_covered_erode_px=-1", "roi.silhouette_covered_erode_px"),
    ("localize.tracker.stop_frames=1", "tracker.stop_frames"),
    ("localize.tracker.min_iou=1.5", "tracker.min_iou"),
    ("localize.wheels.band_fraction=0", "wheels.band_fraction"),
    ("classifier=no_such_model.onnx", "classifier=no_such_model.onnx: no such file"),
])
def test_a_bad_setting_is_named_before_any_case_runs(override: str, message: str):
    with pytest.raises(ConfigError, match=message.replace(".", r"\.")):
        BenchmarkSettings.from_config(composed(override))


@pytest.mark.parametrize(("script_name", "program"), [("run.py", "localization_benchmark"),
                                                     ("shadow_oracle.py", "shadow_oracle")])
def test_the_script_refuses_a_bad_setting_in_one_line(tmp_path: Path, script_name: str, program: str):
    script = PROJECT_ROOT / "experiments" / "localization_benchmark" / script_name
    run = subprocess.run([sys.executable, str(script), "split=train", f"out={tmp_path / 'run'}"],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    assert run.stderr.strip().splitlines() == [f"{program}: error: split: must be dev, heldout or both, got 'train'"]
    assert not (tmp_path / "run" / "cases.csv").exists()


@pytest.mark.slow
def test_the_development_subset_holds_its_rates(tmp_path: Path):
    """The first 24 development seeds end to end with the true model (two workers): rates at least those this
    subset reached when the benchmark was last tuned, and the report's files written; their key-point stage,
    captured, replays to the run's paper estimates with the run's settings, and moves only the cases placed by one
    wheel when one wheel may not place a box; refitted, to the run's whole records, and, of the cases the paper's
    method does not place, without the fit from the silhouette exactly those fitted from it are not localized."""
    settings = BenchmarkSettings.from_config(composed("split=dev", f"cases={GATE_SEEDS}", "workers=2",
                                                      f"capture={tmp_path / 'capture'}"))
    outcomes = list(run_benchmark(settings))
    frame = pd.DataFrame([o.row for o in outcomes])
    assert list(frame["seed"]) == list(range(GATE_SEEDS))
    grouped = with_groups(frame)
    localized = int(grouped["localized"].sum())
    fit_within = int(grouped["fit_within"].sum())
    assert localized >= GATE_LOCALIZED, grouped[["seed", "reason"]][~grouped["localized"].astype(bool)]
    assert fit_within >= GATE_FIT_WITHIN
    assert int(grouped["key_points_found"].fillna(0).sum()) >= GATE_KEY_POINTS
    written = write_report(frame, tmp_path, "gate", [o.picture_bgr for o in outcomes if o.picture_bgr is not None])
    assert {p.name for p in written} >= {"cases.csv", "groups.csv", "report.md", "errors.png"}
    run = read_cases(tmp_path)  # the written run is one the comparison of two runs reads
    gates = {g.gate: g for g in compare_runs(run, run).gates}
    assert gates["fit_within"].after_pct == pytest.approx(100.0 * fit_within / grouped["fit_within"].count())
    captures = read_captures(tmp_path / "capture")
    paper = ["key_point", "paper_position_pct", "paper_heading_deg"]
    replayed = pd.DataFrame(replay(captures, settings.localize))
    pd.testing.assert_frame_equal(replayed[paper], frame[paper], check_dtype=False)  # to the digit
    detectors = settings.localize.detectors
    no_lone_wheel = replace(settings.localize, detectors=replace(detectors, wheels=replace(detectors.wheels,
                                                                                           one_wheel=False)))
    moved = pd.DataFrame(replay(captures, no_lone_wheel))
    changed = ~(moved[paper].fillna(-1).eq(frame[paper].fillna(-1)).all(axis=1))
    by_one_wheel = frame["key_point"].eq("wheel")
    assert by_one_wheel.any() and changed.equals(by_one_wheel)
    record = ["status", "reason_code", "notes", "key_point", "paper_position_pct", "fit_position_pct", "fit_heading_deg",
              "fit_iou", "fit_start", "fit_sigma_position_mm", "fit_sigma_heading_deg"]
    refitted = pd.DataFrame(replay(captures, settings.localize, refit=True, workers=2))
    pd.testing.assert_frame_equal(refitted[record], frame[record], check_dtype=False)  # the whole record, to the digit
    pipeline = settings.localize.pipeline
    unplaced = frame.index[frame["key_point"].eq("")]  # the flag acts only where the paper's placement is not made
    unfitted = pd.DataFrame(replay([captures[i] for i in unplaced], replace(settings.localize, pipeline=replace(
        pipeline, fit_from_silhouette=False)), refit=True, workers=2), index=unplaced)
    unplaced_frame = frame.loc[unplaced]
    lost = unplaced_frame["localized"].astype(bool) & ~unfitted["localized"].astype(bool)
    from_silhouette = unplaced_frame["fit_start"].eq("silhouette")
    assert from_silhouette.any() and lost.equals(from_silhouette)
    assert not frame.loc[frame["key_point"].ne(""), "fit_start"].eq("silhouette").any()
    kept = unplaced[~lost.to_numpy()]  # may be none: the subset's unplaced cases are all fitted from the silhouette
    pd.testing.assert_frame_equal(unfitted.reindex(columns=record).loc[kept], unplaced_frame.loc[kept, record],
                                  check_dtype=False)


def test_a_whole_car_whose_shadow_alone_reaches_the_frame_edge_is_localized(settings: BenchmarkSettings):
    """Development seed 81: a Porsche Panamera stopped 19 px above the frame's bottom, its cast shadow running off the
    frame. Its blob touches the edge, its own pixels do not: it is localized, the fit within 1 % and 1 deg (0.28 %,
    0.13 deg; before, `touches_edge`)."""
    case = draw_case(81, settings.cameras, RoadLayout(**settings.site["layout"]), settings.draw)
    camera = settings.cameras[case.camera_name]
    row = run_case(case, "dev", settings.site, camera, settings.draw, settings.visibility, settings.localize).row
    assert row["localized"] and row["reason_code"] == "", row["reason"]
    assert row["fit_position_pct"] <= 1.0 and row["fit_heading_deg"] <= 1.0


class FrameLog:
    """Stands in for the localizer: keeps each frame's index and digest, and makes no record."""

    def __init__(self) -> None:
        self.frames: list[tuple[int, str]] = []

    def process(self, frame_index: int, frame_bgr: np.ndarray) -> list:
        self.frames.append((frame_index, hashlib.sha1(frame_bgr.tobytes()).hexdigest()))
        return []


def test_the_start_kept_after_the_shadow_refit_turns_a_far_car_the_right_way(settings: BenchmarkSettings):
    """Development seed 192: a white Hyundai Elantra 37 m away (205 mm of road a pixel) with no key point found, fitted
    from its silhouette's two start headings. The start that overlaps best before the road's shadow is taken out ends
    across the car (8.7 %, 66.9 deg); with `pipeline.keep_start_after_shadow` each start is refitted without the
    shadow first, the other one overlaps best and the fit is within 1 % and 1 deg (0.30 %, 0.74 deg). (Its wheels are
    found with the predicted model's wheelbase pairing them: that is turned off here, the silhouette's starts tested.)"""
    case = draw_case(192, settings.cameras, RoadLayout(**settings.site["layout"]), settings.draw)
    camera, localize = settings.cameras[case.camera_name], settings.localize
    wheels = replace(localize.detectors.wheels, model_wheelbase_tolerance=0.0, partner_wheelbase_tolerance=0.0)
    localize = replace(localize, detectors=replace(localize.detectors, wheels=wheels))
    rows = {keep: run_case(case, "dev", settings.site, camera, settings.draw, settings.visibility,
                           replace(localize, pipeline=replace(localize.pipeline, keep_start_after_shadow=keep))).row
            for keep in (False, True)}
    assert rows[False]["fit_start"] == rows[True]["fit_start"] == "silhouette"
    assert rows[False]["fit_heading_deg"] > 45.0
    assert rows[True]["fit_position_pct"] <= 1.0 and rows[True]["fit_heading_deg"] <= 1.0


def test_a_case_with_no_stop_record_by_the_lookahead_reads_every_frame_of_the_whole_scene_once(
        settings: BenchmarkSettings, tmp_path: Path):
    """Development seed 81 on a 320 x 180 camera, and no record: the localizer is given the whole scene's frames once
    each, in order, and the same as the whole scene's video decodes, though the first STOP_LOOKAHEAD_FRAMES past the
    stop came from a shorter video written first."""
    case = draw_case(81, settings.cameras, RoadLayout(**settings.site["layout"]), settings.draw)
    full = settings.cameras[case.camera_name]
    small = replace(full, focal_px=full.focal_px / 4, width_px=full.width_px // 4, height_px=full.height_px // 4)
    spec = case.scene_spec(settings.site, small, settings.draw)
    log, folder = FrameLog(), tmp_path / "case"
    folder.mkdir()
    run = localize_stopped_car(spec, log, folder)  # type: ignore[arg-type]
    write_video(spec, tmp_path / "whole.avi")
    whole = [(index, hashlib.sha1(frame.tobytes()).hexdigest())
             for index, frame in enumerate(iter_frames(tmp_path / "whole.avi"))]
    first_part = spec.stop_frame(spec.cars[0]) + STOP_LOOKAHEAD_FRAMES
    assert run.record is None and run.frames == spec.frame_count == len(whole) > first_part
    assert log.frames == whole
    assert sorted(path.name for path in folder.iterdir()) == [
        f"{spec.name}_{first_part}.avi", f"{spec.name}_{spec.frame_count}.avi"]


def test_a_car_without_plates_differs_from_one_with_them_only_where_its_plate_is():
    """The Spirior's rear towards the camera, 10 m up the road: rendered without plates, the pixels that change
    all lie within the true rear plate's image (grown by 2 px for antialiasing), and its truth holds no plate."""
    from vehloc.synth.render import render_car
    from vehloc.synth.road import render_road

    camera, pose, model = CAMERA.camera(), CarPose(0.0, 10000.0, 90.0), model_by_id(9)
    road = render_road(camera, RoadLayout(lane_count=3, lane_width_mm=3500.0), np.random.default_rng(0))
    with_plates = render_car(model, (180, 180, 180), pose, camera, road)
    without = render_car(model, (180, 180, 180), pose, camera, road, plates=False)
    changed = np.argwhere(np.any(with_plates.image_bgr != without.image_bgr, axis=2))[:, ::-1]
    corners = with_plates.plates["rear"].corners_px
    assert len(changed) > 100
    assert np.all(changed >= corners.min(axis=0) - 2) and np.all(changed <= corners.max(axis=0) + 2)
    assert without.plates == {} and set(with_plates.plates) == {"front", "rear"}


@pytest.mark.parametrize(("method", "offset_pct", "turn_deg", "within"), [
    ("fit", 0.9, 0.0, True), ("fit", 1.1, 0.0, False), ("fit", 0.0, 1.1, False),
    ("paper", 2.8, 2.4, True), ("paper", 2.9, 0.0, False), ("paper", 0.0, 2.6, False)])
def test_each_method_is_held_to_its_own_bar(method: str, offset_pct: float, turn_deg: float, within: bool):
    """The fit within 1 % of the diagonal and 1 deg, the paper's method within its own 2.85 % and 2.5 deg."""
    from vehloc.benchmark.runner import errors
    from vehloc.geometry.placement import VehicleBox

    truth = VehicleBox(np.array([0.0, 10000.0]), 30.0, 4800.0, 1850.0)
    shift_mm = offset_pct / 100.0 * np.hypot(4800.0, 1850.0)
    moved = VehicleBox(truth.centre_mm + [shift_mm, 0.0], 30.0 + turn_deg, 4800.0, 1850.0)
    row = errors(method, moved, truth)
    assert row[f"{method}_position_pct"] == pytest.approx(offset_pct, abs=1e-9)
    assert row[f"{method}_heading_deg"] == pytest.approx(turn_deg, abs=1e-9)
    assert row[f"{method}_within"] is within


@pytest.mark.slow
def test_the_shadow_oracle_shows_the_fit_held_back_by_the_cars_shadow(tmp_path: Path):
    """`shadow_oracle.py` on dev seeds 0-1: from the true pose the fit on the silhouette as extracted is within 1 %
    and 1 deg on seed 0 only (seed 1 measured 5.0 % off), with the rendered shadow beside the car taken out on both
    (seed 1: 0.69 %), and on the true silhouette on both, as with the shadow out and the car's own pixels all
    weighing 1 (0.10 % and 0.09 %); its files written."""
    script = PROJECT_ROOT / "experiments" / "localization_benchmark" / "shadow_oracle.py"
    out = tmp_path / "oracle"
    run = subprocess.run([sys.executable, str(script), "split=dev", "cases=2", f"out={out}"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    cases = pd.read_csv(out / "cases.csv")
    assert list(cases["seed"]) == [0, 1] and set(cases["status"]) == {"fitted"}
    assert list(cases["as_extracted_within"]) == [True, False]
    assert list(cases["rendered_shadow_out_within"]) == [True, True]
    assert list(cases["true_silhouette_within"]) == [True, True]
    assert list(cases["shadow_out_car_full_within"]) == [True, True]
    assert (out / "report.md").read_text().startswith("# ") and (out / "within.png").stat().st_size > 0
