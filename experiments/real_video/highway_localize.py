"""Localize every car of the real highway video, frame by frame, with the calibration `highway.py` wrote.

    python experiments/real_video/highway.py --out outputs/highway
    python experiments/real_video/highway_localize.py --calibration outputs/highway/calibration.json \
        --model outputs/stanford_cars_12.onnx --out outputs/highway_localize

No ground truth comes with the video, so the checks are the ones a road allows: every centre lies on the
road (between the left curb, as calibrated, and the yellow edge line) and every heading is within 5 degrees
of the lane direction. Writes `records.csv` (vehloc-localize's columns), `checks.csv`, `report.md` and
`overlay.png` (the busiest frames with the estimated boxes drawn back in).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from vehloc.atomic import write_image, write_text
from vehloc.geometry.pipeline.drawing import METHOD_COLOURS_BGR, draw_cuboid
from vehloc.geometry.pipeline.localize import Localizer, Status, VehicleRecord
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.geometry.pipeline.speed_files import write_overlays
from vehloc.geometry.pipeline.track_speed import ModelSource, SpeedStatus
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.infer.classifier import VehicleClassifier
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error

from highway import EXPERIMENT, LEFT_CURB_PX, VIDEO

YELLOW_EDGE_X_MM = 3658.0 + 50.0  # the outer edge of the yellow line (site file: its centre, 100 mm wide)
MAX_OFF_LANE_DEG = 5.0
OVERLAY_FRAMES = 6


def off_lane_deg(heading_deg: np.ndarray) -> np.ndarray:
    """Angle between a heading and the lane direction (the road's Y axis, either way), in degrees."""
    return np.abs((np.asarray(heading_deg) - 90.0 + 90.0) % 180.0 - 90.0)


def checks(records: pd.DataFrame, left_curb_x_mm: float) -> pd.DataFrame:
    """Per method: localized records, their tracks, and how many lie on the road and along the lane."""
    rows = []
    for method, group in records[records.status == Status.LOCALIZED].groupby("method"):
        on_road = group.centre_x_mm.between(left_curb_x_mm, YELLOW_EDGE_X_MM)
        along = off_lane_deg(group.heading_deg) <= MAX_OFF_LANE_DEG
        rows.append({"method": method, "records": len(group), "tracks": group.track_id.nunique(),
                     "frames": group.frame.nunique(), "centre_on_road": int(on_road.sum()),
                     "heading_within_5_deg": int(along.sum()),
                     "max_off_lane_deg": float(off_lane_deg(group.heading_deg).max()),
                     "centre_x_range_m": f"{group.centre_x_mm.min() / 1000:.2f} .. {group.centre_x_mm.max() / 1000:.2f}"})
    return pd.DataFrame(rows)


def overlay(records: list[VehicleRecord], localizer: Localizer, path: Path) -> list[int]:
    """The frames with the most localized vehicles, their boxes drawn in (paper green, fit blue); the frames."""
    by_frame: dict[int, list[VehicleRecord]] = {}
    for record in records:
        if record.status == Status.LOCALIZED:
            by_frame.setdefault(record.frame, []).append(record)
    busiest = sorted(sorted(by_frame, key=lambda f: -len(by_frame[f]))[:OVERLAY_FRAMES])
    tiles = []
    for index, frame in enumerate(iter_frames(VIDEO)):
        if index not in busiest:
            continue
        canvas = frame.copy()
        for record in by_frame[index]:
            for estimate in record.estimates:
                draw_cuboid(canvas, localizer.calibration.camera, estimate.box, record.dims_mm[2],
                            METHOD_COLOURS_BGR[estimate.method])
        cv2.putText(canvas, f"frame {index}", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1)
        tiles.append(cv2.resize(canvas, None, fx=2, fy=2, interpolation=cv2.INTER_NEAREST))
    while len(tiles) % 3:
        tiles.append(np.zeros_like(tiles[0]))
    write_image(path, np.vstack([np.hstack(tiles[i:i + 3]) for i in range(0, len(tiles), 3)]))
    return busiest


@exit_on_error("experiments/real_video/highway_localize.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calibration", type=Path, required=True, help="calibration.json written by highway.py")
    parser.add_argument("--model", type=Path, required=True, help="an ONNX classifier written by vehloc-export")
    parser.add_argument("--out", type=Path, default=Path("outputs/highway_localize"))
    parser.add_argument("--max-frames", type=int, default=None)
    parser.add_argument("--set", nargs="*", default=[], metavar="SETTING=VALUE",
                        help="vehloc-localize settings over experiment=highway's (tracker.motion_frames=0)")
    args = parser.parse_args()

    settings = LocalizeSettings.compose([EXPERIMENT, *args.set])  # a bad --set refused before the model is read
    calibration = read_calibration(args.calibration)
    localizer = Localizer(VehicleClassifier.from_onnx(args.model), calibration, settings)
    run = localize_video(localizer, VIDEO, args.out, max_frames=args.max_frames, pictures=False)
    records = pd.read_csv(args.out / "records.csv")
    left_curb_x_mm = float(calibration.road_to_image.inverse(LEFT_CURB_PX)[:, 0].mean())
    table = checks(records, left_curb_x_mm)
    write_text(args.out / "checks.csv", table.to_csv(index=False))
    shown = overlay(list(run.records), localizer, args.out / "overlay.png")
    speed_frames = write_overlays(VIDEO, list(run.vehicles), args.out)
    measured = [v for v in run.vehicles if v.status == SpeedStatus.MEASURED]
    speeds = np.array([v.speed.speed_kmh for v in measured])
    sigmas = np.array([v.speed.sigma_kmh for v in measured])
    unknown = sum(v.model_source == ModelSource.UNKNOWN for v in measured)
    reasons = records[records.status != Status.LOCALIZED].groupby("reason_code")["reason"].agg(["size", "first"])
    lines = [
        "# Real video: every car localized frame by frame",
        "",
        f"{run.frames} frames of {VIDEO.name}; {len(run.records)} vehicle records, {run.localized} localized. "
        f"The road runs from the left curb (X = {left_curb_x_mm / 1000:.2f} m, calibrated) to the yellow line's "
        f"outer edge (X = {YELLOW_EDGE_X_MM / 1000:.2f} m); the lane direction is the road's Y axis.",
        "",
        markdown_table(table) if len(table) else "No record was localized.",
        "",
        "Records not localized, by reason code (with one record's reason):",
        "",
        *(f"- {row['size']} x `{code}` ({row['first']})" for code, row in reasons.sort_values("size", ascending=False).iterrows()),
        "",
        f"![overlay](overlay.png) frames {', '.join(map(str, shown))}: paper's method green, model fit blue.",
        "",
        f"Speeds (`tracks.csv`): {len(run.vehicles)} vehicles tracked, {len(measured)} with a speed"
        + (f" ({unknown} by the bottom of its box: no likely model's size)" if unknown else "")
        + (f": median {np.median(speeds):.1f} km/h (5th-95th percentile {np.percentile(speeds, 5):.1f}-"
           f"{np.percentile(speeds, 95):.1f}), median 1-sigma {np.median(sigmas):.1f} km/h" if len(measured) else "")
        + "; the others by reason code: "
        + ", ".join(f"{n} x `{code}`" for code, n in pd.Series([v.speed.code.value for v in run.vehicles
                                                              if v.status != SpeedStatus.MEASURED]).value_counts().items())
        + ".",
        "",
        "![speeds](speeds.png)",
        "",
        *(f"![frame {p.stem}]({p.name})" for p in speed_frames),
    ]
    write_text(args.out / "report.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
