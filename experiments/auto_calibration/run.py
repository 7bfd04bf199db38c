"""Cameras calibrated by the vehicles they see, against the truth and against the marker calibration: per camera
set-up (`conf/scene/traffic_cam_*`: heights 4-15 m, 30-90 degree lenses, tilts 8-40 degrees, the road at 3-30 degrees
to the optical axis, rolls up to 3 degrees, at 1920x1080, 1280x720 and 320x240; 90 s of traffic), one pass over the
video gathers the traffic, and the camera is calibrated from it four ways: the scale from the recognised models
(the exported classifier's vote; `recognised_expected`: each voted model at the vote's expected dimensions), from the
catalog's mean car (Dubská's rule) and from the true models (the oracle, each track matched to the scene's car whose
boxes it follows). Each is scored against the scene's true camera (focal length, tilt, roll, height, distances along
and across the road between the lanes' points), and the speeds are
measured with the recognised-models calibration and with the markers' (`vehloc-calibrate mode=detect`, `guess` at
320x240) and scored with the benchmark's rules.

    python experiments/auto_calibration/run.py --model demo_data/model.onnx --out outputs/auto_calibration
    python experiments/auto_calibration/run.py --model demo_data/model.onnx --out outputs/shared_blobs --workers 8 \
        --set tracker.motion_frames=5 tracker.max_shared_frames=50

The development cases (`traffic_720p`, `traffic_240p`, `traffic_1080p`, seed 0: the camera of the speed benchmark)
are the ones the settings of `conf/calibrate/auto_calibration/` were chosen on; the eight set-ups (seed 300) were
rendered after those choices and not tuned on. Writes per case its folder (`scene/`, `calibration/` from the markers, `auto_<source>/` per scale
source, `localize_<calibration>/`, `score_<calibration>/`), and `auto_calibration.csv`, `.md`, `vehicles_needed.csv`
and `auto_calibration.png`. Cases already rendered in `--out` are reused (`--force` renders again). `--set` adds
`vehloc-localize` settings to every case's (the traffic's gathering and both speed runs), `--workers` runs that many
cases side by side.
"""

from __future__ import annotations

import argparse
import io
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.atomic import write_bytes, write_text
from vehloc.benchmark.oracle import catalog_metadata
from vehloc.benchmark.side_by_side import in_order, worker_classifier
from vehloc.demo.table2_cases import calibrate_case, render_case, scene_spec
from vehloc.errors import VehlocError, exit_on_error
from vehloc.geometry.auto_calibration import combine_heights
from vehloc.geometry.outcome import FailedEstimate
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import CameraCalibration, read_calibration
from vehloc.geometry.pipeline.auto_calibrate import (
    AutoCalibration,
    AutoCalibrationParams,
    ModelOfTrack,
    VehicleModel,
    auto_calibrate,
    collect_traffic,
    mean_size_model,
    recognised_models,
)
from vehloc.geometry.pipeline.auto_calibration_files import write_auto_calibration_files
from vehloc.geometry.pipeline.brno_files import read_ground_truth, read_results
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.speed_eval import score_speeds
from vehloc.geometry.pipeline.speed_report import write_score
from vehloc.geometry.pipeline.tracker import VehicleTrack
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.geometry.truth import SceneTruth, read_scene_truth
from vehloc.infer.classifier import VehicleClassifier
from vehloc.tables import markdown_table

SETUPS = ["traffic_cam_a_1080p", "traffic_cam_b_1080p", "traffic_cam_c_1080p", "traffic_cam_d_720p",
          "traffic_cam_e_720p", "traffic_cam_f_720p", "traffic_cam_g_240p", "traffic_cam_h_240p"]
SPLITS = {"dev": [("traffic_720p", 0), ("traffic_240p", 0), ("traffic_1080p", 0)],
          "heldout": [(name, 300) for name in SETUPS]}
SOURCES = ("recognised", "recognised_expected", "mean_size", "true_model")
VEHICLE_COUNTS = (10, 20, 50, 100)
SUBSETS = 200
BARS = {"median_scale_error_percent": 2.0, "worst_scale_error_percent": 5.0,
        "median_along_error_percent": 2.0, "median_speed_error_kmh": 1.0}


def low_resolution(scene: str) -> bool:
    return scene.endswith("240p")


def localize_overrides(scene: str) -> list[str]:
    """The localization's settings per size (as the speed benchmark's): the background model at full resolution at
    320x240."""
    return ["experiment=traffic", "roi.scale=1"] if low_resolution(scene) else ["experiment=traffic"]


@dataclass(frozen=True)
class Case:
    split: str
    scene: str
    seed: int

    @property
    def name(self) -> str:
        return f"{self.scene}_seed{self.seed}"


def true_models(truth: SceneTruth) -> ModelOfTrack:
    """The oracle: each track the model of the scene's car whose (exclusive) boxes it overlaps by IoU > 0.5 in most of
    its frames (at least three); None when no car is."""
    metadata = catalog_metadata()

    def model_of(track: VehicleTrack) -> VehicleModel | None:
        votes = np.zeros(len(truth.cars), int)
        for frame, box in zip(track.frames, track.boxes):
            for index, car in enumerate(truth.cars):
                if frame < len(car.boxes) and car.boxes[frame] is not None:
                    if box.iou(car.boxes[frame]) > 0.5:
                        votes[index] += 1
        if votes.max(initial=0) < 3:
            return None
        car = truth.cars[int(np.argmax(votes))]
        return VehicleModel(metadata.shape_of(car.model_id), car.model, car.model_id, 0.0)

    return model_of


def angles_deg(camera: PinholeCamera) -> tuple[float, float]:
    """The camera's tilt below the horizon and its roll (deg), in any world frame with Z up."""
    return float(np.degrees(np.arcsin(-camera.R[2, 2]))), float(np.degrees(np.arcsin(camera.R[0, 2])))


def distance_errors(truth_camera: PinholeCamera, camera: PinholeCamera, lines_y_mm: list[float]) -> dict[str, float]:
    """Distances between road points across the lanes (X -3500, 0, 3500 mm) and along the measured stretch (every 2 m
    between the first and last measurement line), through the true camera's pixels and back onto the calibrated
    camera's road: the signed median of measured / true - 1 over every pair (the scale's error), and the medians of the
    absolute errors of the pairs along the road and across it (%)."""
    xs = np.array([-3500.0, 0.0, 3500.0])
    ys = np.arange(min(lines_y_mm), max(lines_y_mm) + 1.0, 2000.0)
    points = np.array([[x, y] for x in xs for y in ys])
    measured = camera.image_to_road(truth_camera.road_to_image()(points))
    first, second = np.triu_indices(len(points), k=1)
    true_mm = np.linalg.norm(points[first] - points[second], axis=1)
    ratio = np.linalg.norm(measured[first] - measured[second], axis=1) / true_mm - 1.0
    along = points[first, 0] == points[second, 0]
    across = points[first, 1] == points[second, 1]
    return {"scale_error_percent": 100 * float(np.median(ratio)),
            "along_error_percent": 100 * float(np.median(np.abs(ratio[along]))),
            "across_error_percent": 100 * float(np.median(np.abs(ratio[across])))}


def calibration_row(result: AutoCalibration | FailedEstimate, truth: SceneTruth, lines_y_mm: list[float]) -> dict[str, object]:
    """One automatic calibration against the truth."""
    if isinstance(result, FailedEstimate):
        return {"refused": str(result)}
    true_tilt, true_roll = angles_deg(truth.camera)
    tilt, roll = angles_deg(result.camera)
    return {"refused": "", "vehicles": result.scale.vehicles,
            "focal_error_percent": 100 * (result.focal_px / truth.camera.focal_px - 1.0),
            "focal_sigma_percent": 100 * result.focal_sigma_px / result.focal_px,
            "tilt_error_deg": tilt - true_tilt, "roll_error_deg": roll - true_roll,
            "height_error_percent": 100 * (result.scale.height_mm / truth.camera.centre_mm[2] - 1.0),
            "height_sigma_percent": 100 * result.scale.sigma_fraction,
            **distance_errors(truth.camera, result.camera, lines_y_mm)}


def subset_scales(relative: np.ndarray, doubts: np.ndarray, rng: np.random.Generator) -> list[dict[str, object]]:
    """The scale from random subsets of n of the vehicles (n in VEHICLE_COUNTS, as far as there are), their heights
    relative to the true one: the RMS and spread of the subsets' error and the mean 1-sigma they report (%)."""
    rows = []
    for n in VEHICLE_COUNTS:
        if n > len(relative):
            continue
        combined = [combine_heights(relative[pick], doubts[pick])
                    for pick in (rng.choice(len(relative), n, replace=False) for _ in range(SUBSETS))]
        errors = 100 * (np.array([c.height_mm for c in combined]) - 1.0)
        rows.append({"vehicles": n, "error_rms_percent": float(np.sqrt(np.mean(errors ** 2))),
                     "error_std_percent": float(np.std(errors)),
                     "reported_sigma_percent": float(np.mean([100 * c.sigma_fraction for c in combined]))})
    return rows


def vehicles_needed(result: AutoCalibration, truth: SceneTruth, seed: int = 0) -> list[dict[str, object]]:
    """`subset_scales` of one case's vehicles."""
    relative = np.array([v.height_mm for v in result.vehicles]) / truth.camera.centre_mm[2]
    return subset_scales(relative, np.array([v.size_doubt for v in result.vehicles]), np.random.default_rng(seed))


def measure_speeds(case: Case, folder: Path, name: str, calibration: CameraCalibration,
                   classifier: VehicleClassifier, overrides: list[str]) -> dict[str, float]:
    """The case's speeds with one calibration (`overrides` beside the size's localization settings), scored with
    the benchmark's rules."""
    settings = LocalizeSettings.compose(localize_overrides(case.scene) + overrides)
    localize_video(Localizer(classifier, calibration, settings),
                   folder / "scene" / "video.avi", folder / f"localize_{name}", pictures=False, progress=False)
    score = score_speeds(read_results(folder / f"localize_{name}" / "system_vehloc.json"),
                         read_ground_truth(folder / "scene" / "gt_data.json"), calibration.image_size_px)
    summary = write_score(score, folder / f"score_{name}", f"{case.name}, {name} calibration")
    return {f"{name}_{key}": summary[key] for key in ("recall", "mean_error_kmh", "median_error_kmh", "p95_error_kmh",
                                                       "mean_distance_error_percent")}


def pooled_needed(out: Path, table: pd.DataFrame, seed: int = 0) -> pd.DataFrame:
    """`subset_scales` per source of the held-out set-ups' pooled vehicles (each vehicle's height relative to its
    scene's true camera height)."""
    rng = np.random.default_rng(seed)
    rows = []
    for source in SOURCES:
        relative, doubts = [], []
        for case in table[(table["split"] == "heldout") & (table["source"] == source)]["case"]:
            vehicles_csv = out / case / f"auto_{source}" / "vehicles.csv"
            if not vehicles_csv.is_file():
                continue
            vehicles = pd.read_csv(vehicles_csv)
            true_height = read_scene_truth(out / case / "scene" / "ground_truth.json").camera.centre_mm[2]
            relative += list(vehicles["camera_height_mm"] / true_height)
            doubts += list(vehicles["size_doubt"])
        rows += [{"source": source, "pooled_from": len(relative), **row}
                 for row in subset_scales(np.array(relative), np.array(doubts), rng)]
    return pd.DataFrame(rows)


def run_case(case: Case, folder: Path, params: AutoCalibrationParams, force: bool,
             overrides: list[str]) -> tuple[list[dict[str, object]], list[dict[str, object]]]:
    """The case's rows (one per scale source, the speeds beside the recognised one) and its vehicles-needed rows,
    with the process's classifier (`in_order`'s) and `overrides` beside the size's localization settings."""
    classifier = worker_classifier()
    spec = scene_spec(case.scene, [f"scene.traffic.seed={case.seed}", f"scene.seed={case.seed}"])
    if force or not (folder / "scene" / "gt_data.json").is_file():
        render_case(spec, folder, 0.5 if low_resolution(case.scene) else 2.0)
    if force or not (folder / "calibration" / "calibration.json").is_file():
        calibrate_case(folder, "guess" if low_resolution(case.scene) else "detect", 5000.0)
    truth = read_scene_truth(folder / "scene" / "ground_truth.json")
    lines = list(spec.measurement_lines_y_mm)
    settings = LocalizeSettings.compose(localize_overrides(case.scene) + overrides)
    started = time.perf_counter()
    evidence = collect_traffic(folder / "scene" / "video.avi", params, settings, progress=False)
    gathered_s = time.perf_counter() - started
    sources = {"recognised": recognised_models(classifier, params.recognised_size),
               "recognised_expected": recognised_models(classifier, "expected"),
               "mean_size": mean_size_model(classifier), "true_model": true_models(truth)}
    rows, needed, results = [], [], {}
    for source, model_of in sources.items():
        result = auto_calibrate(evidence, model_of, params, settings.pipeline.border_margin_px)
        results[source] = result
        if not isinstance(result, FailedEstimate):
            write_auto_calibration_files(result, evidence.background_bgr, folder / f"auto_{source}", 5000.0,
                                         {"video": str(folder / "scene" / "video.avi"), "scale_source": source})
            needed += [{"case": case.name, "split": case.split, "source": source, **row}
                       for row in vehicles_needed(result, truth)]
        rows.append({"case": case.name, "split": case.split, "scene": case.scene, "source": source,
                     "size_px": f"{truth.camera.width_px}x{truth.camera.height_px}", "tracks": len(evidence.tracks),
                     "frames": evidence.frames, "gather_fps": evidence.frames / gathered_s,
                     **calibration_row(result, truth, lines)})
    speeds: dict[str, float] = {}
    marker = read_calibration(folder / "calibration" / "calibration.json")
    speeds |= measure_speeds(case, folder, "markers", marker, classifier, overrides)
    if not isinstance(results["recognised"], FailedEstimate):
        automatic = results["recognised"].camera_calibration(str(folder / "auto_recognised" / "calibration.json"))
        speeds |= measure_speeds(case, folder, "auto", automatic, classifier, overrides)
    rows[0] |= speeds
    return rows, needed


def plot(table: pd.DataFrame) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (left, right) = plt.subplots(1, 2, figsize=(13, 4.8), dpi=110)
    cases = list(dict.fromkeys(table["case"]))
    positions = np.arange(len(cases))
    colours = {"recognised": "#3870a8", "recognised_expected": "#8fb3d9", "mean_size": "#c0504d",
               "true_model": "#4f9a5a"}
    for offset, source in zip((-0.3, -0.1, 0.1, 0.3), SOURCES):
        rows = table[table["source"] == source].set_index("case").reindex(cases)
        left.bar(positions + offset, rows["scale_error_percent"], 0.2, color=colours[source], label=source)
    left.axhspan(-2, 2, color="#dddddd", zorder=0, label="±2 % (median bar)")
    left.set_xticks(positions, cases, rotation=60, ha="right", fontsize=7)
    left.set_ylabel("scale error (%)")
    left.set_title("road distances' scale by source of the vehicles' size")
    left.legend(fontsize=7)
    recognised = table[table["source"] == "recognised"].set_index("case").reindex(cases)
    right.bar(positions - 0.2, recognised.get("auto_median_error_kmh", np.nan), 0.4, label="automatic", color="#3870a8")
    right.bar(positions + 0.2, recognised.get("markers_median_error_kmh", np.nan), 0.4, label="markers", color="#999999")
    right.axhline(1.0, color="#c0504d", linewidth=1, label="1 km/h (median bar)")
    right.set_xticks(positions, cases, rotation=60, ha="right", fontsize=7)
    right.set_ylabel("median speed error (km/h)")
    right.set_title("speeds: automatic calibration beside the markers'")
    right.legend(fontsize=7)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    return buffer.getvalue()


def verdicts(table: pd.DataFrame) -> list[str]:
    """The issue's bars over the held-out set-ups, with the recognised models' scale."""
    rows = table[(table["split"] == "heldout") & (table["source"] == "recognised")]
    if rows.empty:
        return []
    scale = rows["scale_error_percent"].abs()
    figures = {"median_scale_error_percent": scale.median(), "worst_scale_error_percent": scale.max(),
               "median_along_error_percent": rows["along_error_percent"].median(),
               "median_speed_error_kmh": rows["auto_median_error_kmh"].median()}
    return [f"- {key}: {figures[key]:.2f} ({'met' if figures[key] <= bar else 'not met'}, bar {bar:g})"
            for key, bar in BARS.items()]


def sources_side_by_side(table: pd.DataFrame) -> pd.DataFrame:
    """Per case the absolute scale error of each source, and how much the recognised models' beats the mean car's."""
    wide = table.pivot_table(index=["split", "case"], columns="source", values="scale_error_percent").abs()
    wide = wide.reindex(columns=[s for s in SOURCES if s in wide.columns]).reset_index()
    if {"recognised", "mean_size"} <= set(wide.columns):
        wide["mean_size_minus_recognised"] = wide["mean_size"] - wide["recognised"]
    return wide


def markdown(table: pd.DataFrame, needed: pd.DataFrame, pooled: pd.DataFrame, model: str) -> str:
    columns = ["split", "case", "source", "vehicles", "focal_error_percent", "focal_sigma_percent", "tilt_error_deg",
               "roll_error_deg", "height_error_percent", "height_sigma_percent", "scale_error_percent",
               "along_error_percent", "across_error_percent"]
    speed_columns = ["split", "case", "markers_median_error_kmh", "markers_mean_error_kmh", "auto_median_error_kmh",
                     "auto_mean_error_kmh", "auto_recall", "auto_mean_distance_error_percent"]
    recognised = table[table["source"] == "recognised"]
    lines = [f"# Cameras calibrated by their traffic, classifier {model}", "",
             "Errors against each scene's true camera; `scale_error_percent`: the signed median error of road distances "
             "between the lanes' points over the measured stretch, through the calibration (what a speed is off by); "
             "`along`/`across`: the median absolute error of the pairs along and across the road.", "",
             markdown_table(table[[c for c in columns if c in table]]), "",
             "## Speeds (benchmark rules), the recognised models' calibration beside the markers'", "",
             markdown_table(recognised[[c for c in speed_columns if c in recognised]]), "",
             "## The scale's source, side by side (|scale error| %)", "",
             markdown_table(sources_side_by_side(table)), "",
             "## Bars (held-out set-ups, the recognised models' scale)", "", *verdicts(table), "",
             "## Vehicles needed", "",
             "Random subsets of n of the scaled vehicles (200 each): per case, the median over cases of each case's "
             "figures; pooled, drawn from all held-out set-ups' vehicles (each relative to its own camera's height).",
             "", markdown_table(needed.groupby(["source", "vehicles"])[
                 ["error_rms_percent", "error_std_percent", "reported_sigma_percent"]].median().reset_index())
             if not needed.empty else "(no case had enough vehicles)", "",
             markdown_table(pooled) if not pooled.empty else "(no held-out vehicles)"]
    return "\n".join(lines) + "\n"


@exit_on_error("experiments/auto_calibration/run.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True, help="a classifier exported by vehloc-export")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--split", choices=["dev", "heldout", "all"], default="all")
    parser.add_argument("--only", nargs="*", default=None, help="these scenes only")
    parser.add_argument("--force", action="store_true", help="render and calibrate with the markers again")
    parser.add_argument("--report", action="store_true", help="only the tables and plot again, from --out's CSV files")
    parser.add_argument("--set", nargs="*", default=[], metavar="SETTING=VALUE",
                        help="vehloc-localize settings for every case (the traffic's gathering and the speeds)")
    parser.add_argument("--workers", type=int, default=1, help="cases run side by side (one OpenCV thread each)")
    args = parser.parse_args()
    if args.workers < 1:
        raise VehlocError(f"--workers {args.workers}: must be at least 1")
    splits = ["dev", "heldout"] if args.split == "all" else [args.split]
    cases = [Case(split, scene, seed) for split in splits for scene, seed in SPLITS[split]
             if args.only is None or scene in args.only]
    for scene in {case.scene for case in cases}:
        LocalizeSettings.compose(localize_overrides(scene) + args.set)  # a bad --set refused before any case runs
    if not args.model.is_file():
        raise VehlocError(f"--model {args.model}: no such file")
    VehicleClassifier.from_onnx(args.model)  # a bad model refused here
    if args.report:
        write_report(args.out, pd.read_csv(args.out / "auto_calibration.csv"),
                     pd.read_csv(args.out / "vehicles_needed.csv"), args.model.name)
        return
    params = AutoCalibrationParams.from_config()
    jobs = [(case, args.out / case.name, params, args.force, args.set) for case in cases]
    started = time.perf_counter()
    rows, needed = [], []
    for number, (case, (case_rows, case_needed)) in enumerate(zip(cases, in_order(run_case, jobs, args.workers,
                                                                                  args.model)), 1):
        rows += case_rows
        needed += case_needed
        first = case_rows[0]
        print(f"[{number}/{len(cases)}] {case.name} ({case.split}): "
              + (f"scale {first['scale_error_percent']:+.2f} %, focal {first['focal_error_percent']:+.2f} %, "
                 f"{first['vehicles']} vehicles; speeds median auto {first.get('auto_median_error_kmh', np.nan):.2f} / "
                 f"markers {first.get('markers_median_error_kmh', np.nan):.2f} km/h"
                 if not first["refused"] else f"refused: {first['refused']}")
              + f", {time.perf_counter() - started:.0f} s", flush=True)
        table, needed_table = pd.DataFrame(rows), pd.DataFrame(needed)
        write_text(args.out / "auto_calibration.csv", table.to_csv(index=False, float_format="%.4f"))
        write_text(args.out / "vehicles_needed.csv", needed_table.to_csv(index=False, float_format="%.4f"))
        write_report(args.out, table, needed_table, args.model.name)
    print((args.out / "auto_calibration.md").read_text())


def write_report(out: Path, table: pd.DataFrame, needed: pd.DataFrame, model: str) -> None:
    """`auto_calibration.md` and `.png` from the cases' rows."""
    pooled = pooled_needed(out, table)
    write_text(out / "vehicles_needed_pooled.csv", pooled.to_csv(index=False, float_format="%.4f"))
    write_text(out / "auto_calibration.md", markdown(table, needed, pooled, model))
    write_bytes(out / "auto_calibration.png", plot(table))


if __name__ == "__main__":
    main()
