"""Check the highway clip's localization and speeds against what was read off it by hand.

    python experiments/real_video/highway.py --out outputs/highway
    python experiments/real_video/highway_localize.py --calibration outputs/highway/calibration.json \
        --model outputs/stanford_cars_12.onnx --out outputs/highway_localize
    python experiments/real_video/highway_hand_check.py --calibration outputs/highway/calibration.json \
        --localized outputs/highway_localize --out outputs/highway_hand

Two hand truths:
- `highway_spot_truth.yaml`: vehicles' fronts read in single frames. Each becomes the road point of its front ground
  line; the record whose box holds the spot gives the localized front (the middle of its footprint's end nearest the
  camera: every car on this road drives towards it). A spot passes within `--max-error-m` (1.5 m).
- `highway_crossings.yaml`: every vehicle through image row 180, counted on a slit-scan of that row. Each is matched
  to a measured vehicle of `tracks.csv` in its lane that crosses the row within `--tolerance-frames` (12).

Writes `spot_check.csv`, `crossings.csv`, `report.md`, `spots.png` (each spot's crop, enlarged: the hand reading red,
its ground point red, the localized footprint blue) and `slit_scan.png` (row 180 of every frame side by side, time to
the right: each hand crossing marked, green where a measured vehicle matched it, red where none did).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from vehloc.atomic import write_image, write_text
from vehloc.benchmark.crossings import CrossingCount, CrossingMatch, match_crossings, read_crossings
from vehloc.benchmark.spot_truth import SpotCheck, check_spot, read_spot_truth, spot_table
from vehloc.errors import DataError, exit_on_error
from vehloc.geometry.camera_calibration import CameraCalibration, read_calibration
from vehloc.geometry.pipeline.localize import Status
from vehloc.geometry.pipeline.track_speed import SpeedStatus
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.tables import markdown_table

from highway import VIDEO

HERE = Path(__file__).resolve().parent
SPOTS = HERE / "highway_spot_truth.yaml"
CROSSINGS = HERE / "highway_crossings.yaml"
CROP_HALF_PX = 40
ENLARGE = 3
RED_BGR = (40, 40, 230)
BLUE_BGR = (255, 160, 40)
GREEN_BGR = (60, 200, 60)
SLIT_PANEL_FRAMES = 430
SLIT_STRETCH = 2


def spot_tile(frame: np.ndarray, check: SpotCheck, road_to_image) -> np.ndarray:
    """The spot's neighbourhood enlarged, with the hand reading, its ground point and the localized front."""
    x, y = check.spot.front_px
    x0 = int(np.clip(x - CROP_HALF_PX, 0, frame.shape[1] - 2 * CROP_HALF_PX))
    y0 = int(np.clip(y - CROP_HALF_PX, 0, frame.shape[0] - 2 * CROP_HALF_PX))
    tile = cv2.resize(frame[y0:y0 + 2 * CROP_HALF_PX, x0:x0 + 2 * CROP_HALF_PX], None, fx=ENLARGE, fy=ENLARGE,
                      interpolation=cv2.INTER_NEAREST)

    def to_tile(points_px: np.ndarray) -> np.ndarray:
        return np.round((np.asarray(points_px) - [x0 - 0.5, y0 - 0.5]) * ENLARGE).astype(np.int32)

    hand = to_tile([[x - 8, y], [x + 8, y]])
    cv2.line(tile, tuple(hand[0]), tuple(hand[1]), RED_BGR, 1)
    cv2.drawMarker(tile, tuple(to_tile(road_to_image(check.truth_mm[None])[0])), RED_BGR, cv2.MARKER_CROSS, 10, 2)
    if check.front_mm is not None:
        front = to_tile(road_to_image(check.front_mm[None])[0])
        cv2.drawMarker(tile, tuple(front), BLUE_BGR, cv2.MARKER_TILTED_CROSS, 10, 2)
        verdict = f"{check.error_mm / 1000:.2f} m"
    else:
        verdict = check.reason
    cv2.putText(tile, f"{check.spot.frame} {check.spot.lane}: {verdict}", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                (255, 255, 255), 1)
    return tile


def write_sheets(checks: list[SpotCheck], count: CrossingCount, matches: list[CrossingMatch],
                 calibration: CameraCalibration, records: pd.DataFrame, out: Path) -> None:
    """`spots.png`, every spot's tile with the localized footprint of its record drawn in, five to a row; and
    `slit_scan.png`, the counting row of every frame with the hand crossings marked."""
    by_frame: dict[int, list[SpotCheck]] = {}
    for check in checks:
        by_frame.setdefault(check.spot.frame, []).append(check)
    tiles, rows = [], []
    row = int(round(count.row_px))
    for index, frame in enumerate(iter_frames(VIDEO)):
        rows.append(frame[row].copy())
        for check in by_frame.get(index, []):
            canvas = frame.copy()
            if check.front_mm is not None:
                record = records[(records.frame == index) & (records.track_id == check.track_id)].iloc[0]
                corners = np.array([[record[f"corner{i}_x_mm"], record[f"corner{i}_y_mm"]] for i in range(4)])
                cv2.polylines(canvas, [np.round(calibration.road_to_image(corners)).astype(np.int32)], True, BLUE_BGR, 1)
            tiles.append(spot_tile(canvas, check, calibration.road_to_image))
    while len(tiles) % 5:
        tiles.append(np.zeros_like(tiles[0]))
    write_image(out / "spots.png", np.vstack([np.hstack(tiles[i:i + 5]) for i in range(0, len(tiles), 5)]))

    scan = np.array(rows)
    panels = []
    for start in range(0, len(scan), SLIT_PANEL_FRAMES):
        part = scan[start:start + SLIT_PANEL_FRAMES]
        part = np.vstack([part, np.zeros((SLIT_PANEL_FRAMES - len(part),) + part.shape[1:], part.dtype)])
        panel = cv2.resize(np.ascontiguousarray(part.transpose(1, 0, 2)), None, fx=SLIT_STRETCH, fy=1,
                           interpolation=cv2.INTER_NEAREST)
        panel = cv2.copyMakeBorder(panel, 18, 0, 0, 0, cv2.BORDER_CONSTANT, value=(0, 0, 0))
        for t in range(0, SLIT_PANEL_FRAMES, 50):
            cv2.putText(panel, str(start + t), (SLIT_STRETCH * t + 2, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.35,
                        (0, 255, 255), 1)
        for match in matches:
            t = match.crossing.frame - start
            if 0 <= t < SLIT_PANEL_FRAMES:
                colour = GREEN_BGR if match.track_id is not None else RED_BGR
                cv2.line(panel, (SLIT_STRETCH * t, 13), (SLIT_STRETCH * t, 17), colour, 2)
                label = f"{match.track_id}" if match.track_id is not None else "none"
                cv2.putText(panel, label, (SLIT_STRETCH * t + 3, 46 if match.crossing.lane == "left" else 186),
                            cv2.FONT_HERSHEY_SIMPLEX, 0.35, colour, 1)
        panels.append(panel)
    write_image(out / "slit_scan.png", np.vstack(panels))


def crossing_table(matches: list[CrossingMatch]) -> pd.DataFrame:
    return pd.DataFrame([{"frame": m.crossing.frame, "lane": m.crossing.lane, "track_id": m.track_id,
                          "track_frame": m.track_frame, "speed_kmh": m.speed_kmh} for m in matches])


@exit_on_error("experiments/real_video/highway_hand_check.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calibration", type=Path, required=True, help="calibration.json written by highway.py")
    parser.add_argument("--localized", type=Path, required=True,
                        help="the folder highway_localize.py wrote (records.csv, tracks.csv, trajectories.csv)")
    parser.add_argument("--spots", type=Path, default=SPOTS, help="the spot-truth YAML")
    parser.add_argument("--crossings", type=Path, default=CROSSINGS, help="the crossings YAML")
    parser.add_argument("--max-error-m", type=float, default=1.5)
    parser.add_argument("--tolerance-frames", type=float, default=12.0)
    parser.add_argument("--out", type=Path, default=Path("outputs/highway_hand"))
    args = parser.parse_args()
    for name in ("max_error_m", "tolerance_frames"):
        if not getattr(args, name) > 0:
            raise DataError(f"--{name.replace('_', '-')} must be positive, got {getattr(args, name)}")
    truth, count = read_spot_truth(args.spots), read_crossings(args.crossings)
    calibration = read_calibration(args.calibration)
    if calibration.camera is None:
        raise DataError(f"{args.calibration}: no camera can be recovered from its homography")
    tables = {}
    for name in ("records", "tracks", "trajectories"):
        path = args.localized / f"{name}.csv"
        if not path.is_file():
            raise DataError(f"{path}: no such file (run highway_localize.py first)")
        tables[name] = pd.read_csv(path)

    checks = [check_spot(s, truth, tables["records"], calibration.camera, args.max_error_m * 1000)
              for s in truth.spots]
    matches = match_crossings(count, tables["tracks"], tables["trajectories"], calibration.road_to_image,
                              lambda x_mm: "left" if x_mm < 0 else "right", args.tolerance_frames)
    spots, crossings = spot_table(checks), crossing_table(matches)
    write_text(args.out / "spot_check.csv", spots.to_csv(index=False))
    write_text(args.out / "crossings.csv", crossings.to_csv(index=False))
    write_sheets(checks, count, matches, calibration, tables["records"], args.out)

    localized = spots[spots.status == Status.LOCALIZED]
    measured = tables["tracks"][tables["tracks"].status == SpeedStatus.MEASURED]
    matched = crossings.track_id.notna()
    lines = [
        "# The highway clip against what was read off it by hand",
        "",
        "## Fronts read in single frames",
        "",
        f"{len(spots)} spots in {spots.frame.nunique()} frames ({(spots.lane == 'left').sum()} in the left lane, "
        f"{(spots.lane == 'right').sum()} in the right); {len(localized)} matched a localized record; "
        f"**{int(spots.within.sum())} of {len(spots)} within {args.max_error_m:g} m**"
        + (f"; error of the localized: median {localized.error_m.median():.2f} m, worst {localized.error_m.max():.2f}"
           f" m, along the road median {localized.error_along_m.median():+.2f} m" if len(localized) else "") + ".",
        "",
        markdown_table(spots[["frame", "lane", "body", "colour", "front_y_px", "truth_y_m", "truth_sigma_along_m",
                              "track_id", "status", "reason", "error_along_m", "error_across_m", "error_m",
                              "within"]].round(2)),
        "",
        "![the spots](spots.png) hand reading and its ground point red, the localized footprint and front blue.",
        "",
        f"## Vehicles through row {count.row_px:g}",
        "",
        f"{len(crossings)} vehicles counted by hand from frame {count.first_frame}; **{int(matched.sum())} have a "
        f"measured speed** in `tracks.csv` (a measured vehicle of their lane crossing within "
        f"{args.tolerance_frames:g} frames); {len(measured)} vehicles measured in all, "
        f"{len(measured) - int(matched.sum())} of them matched to no counted crossing (a vehicle measured twice, or "
        "one seen only far away or before the count's first frame).",
        "",
        markdown_table(crossings.round(1)),
        "",
        "![the slit-scan](slit_scan.png) the counting row of every frame, time to the right; each hand crossing's frame "
        "marked green with the matched track's id, red where none matched.",
    ]
    write_text(args.out / "report.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
