"""Moving vehicles of rendered traffic, localized frame by frame as the highway clip is, against their exact poses.

    python experiments/localization_benchmark/moving.py --split dev --out runs/moving_dev
    python experiments/localization_benchmark/moving.py --split heldout --scene traffic_720p --out runs/moving_720p
    python experiments/localization_benchmark/moving.py --split dev --set pipeline.fit.shadow_passes=0 --out ...

Each seed renders `--duration-s` seconds of the scene's traffic (`conf/scene/traffic_*`: three lanes towards the
camera, cast shadows), every car the Honda Spirior (the true model named) or, with `--model`, every catalog model
and that classifier's vote. The localization is `vehloc-localize experiment=traffic` with every frame recorded and
the model fit started from each track's travel (`pipeline.every_frame`, `pipeline.fit_from_travel`, as
`experiment=highway`), under the camera's exact calibration. Every localized record is matched to the car whose true
box overlaps its box by `--min-iou` (`vehloc.benchmark.moving`). Writes `errors.csv` (one row per record), `report.md`
(per seed and per distance band: records, the near end's error, median and 90th percentile, its median along the
car's heading (+ away from the camera), the share within 1.5 m, the centre's and the heading's median errors) and `errors.png` (the near end's error
against the distance). Development seeds 0-1, held-out seeds 100-101 (`--split`).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from vehloc.atomic import atomic_path, check_output_dir, write_text  # noqa: E402
from vehloc.benchmark.moving import moving_error, read_truth_cars  # noqa: E402
from vehloc.benchmark.oracle import TrueModelClassifier  # noqa: E402
from vehloc.benchmark.runner import exact_calibration  # noqa: E402
from vehloc.demo.table2_cases import render_case, scene_spec  # noqa: E402
from vehloc.errors import DataError, exit_on_error  # noqa: E402
from vehloc.geometry.pipeline.localize import Localizer  # noqa: E402
from vehloc.geometry.pipeline.settings import LocalizeSettings  # noqa: E402
from vehloc.geometry.pipeline.video import iter_frames  # noqa: E402
from vehloc.infer.classifier import VehicleClassifier  # noqa: E402
from vehloc.tables import markdown_table  # noqa: E402

SEEDS = {"dev": (0, 1), "heldout": (100, 101)}
SCENES = ("traffic_240p", "traffic_720p", "traffic_1080p")
TRUE_MODEL_ID = 9  # the Honda Spirior, the paper's test car
DISTANCE_BANDS_M = (0, 20, 30, 40, 60, 200)
WITHIN_M = 1.5  # the highway clip's hand truth's bar


def summary(errors: pd.DataFrame, by: str) -> pd.DataFrame:
    """Per group: records, the near end's error (median, 90th percentile, median along, share within 1.5 m), the
    centre's and the heading's (absolute) median."""
    return errors.groupby(by, observed=True).agg(
        records=("near_end_error_m", "size"), near_end_median_m=("near_end_error_m", "median"),
        near_end_p90_m=("near_end_error_m", lambda e: e.quantile(0.9)),
        near_end_along_median_m=("near_end_along_m", "median"),
        within_1_5_m_pct=("near_end_error_m", lambda e: 100.0 * (e <= WITHIN_M).mean()),
        centre_median_m=("centre_error_m", "median"),
        heading_median_deg=("heading_error_deg", lambda e: e.abs().median()),
    ).reset_index().round(2)


def plot(errors: pd.DataFrame, path: Path, title: str) -> None:
    """The near end's error against the distance, one colour per seed."""
    figure, axis = plt.subplots(figsize=(8, 4.5))
    for seed, group in errors.groupby("seed"):
        axis.scatter(group.distance_m, group.near_end_error_m, s=6, alpha=0.6, label=f"seed {seed}")
    axis.axhline(WITHIN_M, color="grey", linestyle="--", linewidth=1)
    axis.set(xlabel="distance from the camera's foot (m)", ylabel="near end's error (m)", title=title)
    axis.legend()
    figure.tight_layout()
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", dpi=110)
    plt.close(figure)


@exit_on_error("experiments/localization_benchmark/moving.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--split", choices=sorted(SEEDS), default="dev")
    parser.add_argument("--scene", choices=SCENES, default="traffic_240p")
    parser.add_argument("--duration-s", type=float, default=16.0, help="seconds of traffic per seed")
    parser.add_argument("--model", type=Path, default=None,
                        help="an ONNX classifier (vehloc-export): every catalog model, its vote; default: the true model")
    parser.add_argument("--min-iou", type=float, default=0.6, help="a record's box against its car's true box")
    parser.add_argument("--set", nargs="*", default=[], metavar="SETTING=VALUE", help="vehloc-localize settings")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if not args.duration_s > 0:
        raise DataError(f"--duration-s must be positive, got {args.duration_s}")
    if not 0 < args.min_iou <= 1:
        raise DataError(f"--min-iou must be in (0, 1], got {args.min_iou}")
    if args.model is not None and not args.model.is_file():
        raise DataError(f"{args.model}: no such classifier (write one with vehloc-export)")
    check_output_dir(args.out)
    settings = LocalizeSettings.compose(["experiment=traffic", "pipeline.every_frame=true",
                                         "pipeline.fit_from_travel=true"]
                                        + (["roi.scale=1"] if args.scene == "traffic_240p" else []) + args.set)
    classifier = VehicleClassifier.from_onnx(args.model) if args.model is not None else TrueModelClassifier(TRUE_MODEL_ID)

    rows = []
    for seed in SEEDS[args.split]:
        started = time.perf_counter()
        overrides = [f"scene.traffic.seed={seed}", f"scene.seed={seed}", f"scene.traffic.duration_s={args.duration_s}"]
        if args.model is None:
            overrides.append(f"+scene.traffic.model_ids=[{TRUE_MODEL_ID}]")
        spec = scene_spec(args.scene, overrides)
        folder = args.out / "scenes" / f"{args.scene}_seed{seed}"
        video = render_case(spec, folder)
        cars = read_truth_cars(folder / "scene" / "ground_truth.json")
        calibration = exact_calibration(spec.camera)
        localizer = Localizer(classifier, calibration, settings)
        records, matched = 0, 0
        for index, frame in enumerate(iter_frames(video)):
            for record in localizer.process(index, frame):
                records += 1
                error = moving_error(record, cars, calibration.camera.centre_mm, args.min_iou)
                if error is not None:
                    matched += 1
                    rows.append({"scene": args.scene, "seed": seed} | asdict(error))
        print(f"{args.scene} seed {seed}: {len(cars)} cars, {records} records, {matched} matched, "
              f"{time.perf_counter() - started:.0f} s", flush=True)
    if not rows:
        raise DataError("no localized record matched a car: nothing to score")

    errors = pd.DataFrame(rows)
    for name in ("distance", "centre_error", "near_end_error", "near_end_along"):
        errors[f"{name}_m"] = errors.pop(f"{name}_mm") / 1000.0
    errors["distance_band_m"] = pd.cut(errors.distance_m, DISTANCE_BANDS_M).astype(str)
    write_text(args.out / "errors.csv", errors.to_csv(index=False))
    title = (f"{args.scene}, {args.split} seeds {', '.join(map(str, SEEDS[args.split]))}, "
             + ("the true model" if args.model is None else args.model.name))
    plot(errors, args.out / "errors.png", title)
    lines = [f"# Moving vehicles: {title}", "", f"Settings over `experiment=traffic`: {' '.join(args.set) or 'none'}.",
             "", "## Per seed", "", markdown_table(summary(errors, "seed")), "", "## Per distance band", "",
             markdown_table(summary(errors, "distance_band_m")), "", "![errors](errors.png)"]
    write_text(args.out / "report.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
