"""The real highway clip calibrated by its traffic alone, against the US lane standard and the marker calibration.

    python experiments/real_video/highway.py --out outputs/highway
    vehloc-calibrate mode=auto video=../shared/data/traffic/highway_320x240.avi model=outputs/stanford_cars_12.onnx \
        'localize=["experiment=highway"]' hydra.run.dir=outputs/highway_auto
    python experiments/real_video/highway_auto_calibration.py --auto outputs/highway_auto/calibration.json \
        --markers outputs/highway/calibration.json --model outputs/stanford_cars_12.onnx --out outputs/highway_auto_check

The lane markings' corners of `highway_site.yaml` are taken to the image by the marker calibration (0.4 px RMS on the
dash ends) and back onto the road by the automatic one: the lane width (the dashed line to the yellow edge line) and
the dash period they imply, against the US standard (3.66 m, 12.19 m). Then every vehicle's speed with each
calibration (`experiment=highway`), matched by track. Writes `checks.csv`, `speeds.csv`, `report.md` and `speeds.png`.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.atomic import write_bytes, write_text
from vehloc.geometry.camera_calibration import CameraCalibration, read_calibration
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.track_speed import SpeedStatus
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.infer.classifier import VehicleClassifier
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error

from highway import EXPERIMENT, VIDEO

LANE_WIDTH_MM = 3658.0   # 12 ft
DASH_PERIOD_MM = 12192.0  # 40 ft
DASHES = 6
TOLERANCE = 0.05


def lane_checks(auto: CameraCalibration, markers: CameraCalibration) -> pd.DataFrame:
    """The lane width and dash period the automatic calibration gives the marker calibration's image of the site's
    dash ends and yellow line, per dash."""
    dash = np.array([[0.0, DASH_PERIOD_MM * k] for k in range(DASHES)])
    yellow = dash + [LANE_WIDTH_MM, 0.0]
    to_auto = lambda points_mm: auto.road_to_image.inverse(markers.road_to_image(points_mm))  # noqa: E731
    dash_auto, yellow_auto = to_auto(dash), to_auto(yellow)
    along = dash_auto[-1] - dash_auto[0]
    along /= np.linalg.norm(along)
    across = np.array([along[1], -along[0]])
    widths = np.abs((yellow_auto - dash_auto) @ across)
    periods = np.linalg.norm(np.diff(dash_auto, axis=0), axis=1)
    rows = [{"quantity": "lane width", "standard_m": LANE_WIDTH_MM / 1000, "markers_m": LANE_WIDTH_MM / 1000,
             "auto_m": float(np.mean(widths)) / 1000, "auto_range_m": f"{widths.min() / 1000:.2f} .. {widths.max() / 1000:.2f}"},
            {"quantity": "dash period", "standard_m": DASH_PERIOD_MM / 1000, "markers_m": DASH_PERIOD_MM / 1000,
             "auto_m": float(np.mean(periods)) / 1000,
             "auto_range_m": f"{periods.min() / 1000:.2f} .. {periods.max() / 1000:.2f}"}]
    table = pd.DataFrame(rows)
    table["error_percent"] = 100 * (table["auto_m"] / table["standard_m"] - 1.0)
    table["within_5_percent"] = table["error_percent"].abs() <= 100 * TOLERANCE
    return table


def speeds(calibration: CameraCalibration, classifier: VehicleClassifier, out_dir: Path) -> pd.Series:
    """Every measured vehicle's speed (km/h) by track id with this calibration."""
    run = localize_video(Localizer(classifier, calibration, LocalizeSettings.compose([EXPERIMENT])), VIDEO, out_dir,
                         pictures=False, progress=False)
    return pd.Series({v.track_id: v.speed.speed_kmh for v in run.vehicles if v.status == SpeedStatus.MEASURED},
                     dtype=float)


def plot(paired: pd.DataFrame) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5.5, 5), dpi=110)
    axis.scatter(paired["markers_kmh"], paired["auto_kmh"], s=14, color="#3870a8")
    low, high = 0.0, float(np.nanmax(paired[["markers_kmh", "auto_kmh"]].to_numpy())) * 1.1
    axis.plot([low, high], [low, high], color="grey", linewidth=1, label="equal")
    axis.set_xlabel("speed, marker calibration (km/h)")
    axis.set_ylabel("speed, automatic calibration (km/h)")
    axis.set_title("the highway clip's vehicles, both calibrations")
    axis.legend()
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    return buffer.getvalue()


@exit_on_error("experiments/real_video/highway_auto_calibration.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--auto", type=Path, required=True, help="calibration.json of vehloc-calibrate mode=auto")
    parser.add_argument("--markers", type=Path, required=True, help="calibration.json of highway.py")
    parser.add_argument("--model", type=Path, required=True, help="the classifier (the stanford_cars_12 export)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    auto, markers = read_calibration(args.auto), read_calibration(args.markers)
    classifier = VehicleClassifier.from_onnx(args.model)
    checks = lane_checks(auto, markers)
    by_auto = speeds(auto, classifier, args.out / "localize_auto")
    by_markers = speeds(markers, classifier, args.out / "localize_markers")
    paired = pd.DataFrame({"auto_kmh": by_auto, "markers_kmh": by_markers}).dropna()
    paired["ratio"] = paired["auto_kmh"] / paired["markers_kmh"]
    write_text(args.out / "checks.csv", checks.to_csv(index=False, float_format="%.4f"))
    write_text(args.out / "speeds.csv", paired.rename_axis("track_id").to_csv(float_format="%.3f"))
    write_bytes(args.out / "speeds.png", plot(paired))
    report = ["# The highway clip calibrated by its traffic", "", markdown_table(checks), "",
              f"Speeds of the {len(paired)} vehicles measured with both calibrations: median "
              f"{paired['auto_kmh'].median():.1f} km/h (automatic) against {paired['markers_kmh'].median():.1f} km/h "
              f"(markers), median ratio {paired['ratio'].median():.3f}."]
    write_text(args.out / "report.md", "\n".join(report) + "\n")
    print("\n".join(report))


if __name__ == "__main__":
    main()
