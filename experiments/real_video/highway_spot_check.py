"""Check the highway clip's localized records against the vehicles' fronts read by hand.

    python experiments/real_video/highway.py --out outputs/highway
    python experiments/real_video/highway_localize.py --calibration outputs/highway/calibration.json \
        --model outputs/stanford_cars_12.onnx --out outputs/highway_localize
    python experiments/real_video/highway_spot_check.py --calibration outputs/highway/calibration.json \
        --records outputs/highway_localize/records.csv --out outputs/highway_spots

Each spot of `highway_spot_truth.yaml` (a vehicle's front's lower edge read by hand in one frame) becomes the road
point of its front ground line; the record whose box holds the spot gives the localized front (the middle of its
footprint's end nearest the camera: every car on this road drives towards it). A spot passes when the two are within
`--max-error-m` (1.5 m). Writes `spot_check.csv`, `report.md` and `spots.png` (each spot's crop, enlarged: the hand
reading red, the ground point red, the localized footprint blue).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from vehloc.atomic import write_image, write_text
from vehloc.benchmark.spot_truth import SpotCheck, check_spot, read_spot_truth, spot_table
from vehloc.errors import DataError, exit_on_error
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.tables import markdown_table

from highway import VIDEO

TRUTH = Path(__file__).resolve().parent / "highway_spot_truth.yaml"
CROP_HALF_PX = 40
ENLARGE = 3
RED_BGR = (40, 40, 230)
BLUE_BGR = (255, 160, 40)


def spot_tile(frame: np.ndarray, check: SpotCheck, road_to_image) -> np.ndarray:
    """The spot's neighbourhood enlarged, with the hand reading, its ground point and the localized footprint."""
    x, y = check.spot.front_px
    x0 = int(np.clip(x - CROP_HALF_PX, 0, frame.shape[1] - 2 * CROP_HALF_PX))
    y0 = int(np.clip(y - CROP_HALF_PX, 0, frame.shape[0] - 2 * CROP_HALF_PX))
    tile = cv2.resize(frame[y0:y0 + 2 * CROP_HALF_PX, x0:x0 + 2 * CROP_HALF_PX], None, fx=ENLARGE, fy=ENLARGE,
                      interpolation=cv2.INTER_NEAREST)

    def to_tile(points_px: np.ndarray) -> np.ndarray:
        return np.round((np.asarray(points_px) - [x0 - 0.5, y0 - 0.5]) * ENLARGE).astype(np.int32)

    hand = to_tile([[x - 8, y], [x + 8, y]])
    cv2.line(tile, tuple(hand[0]), tuple(hand[1]), RED_BGR, 1)
    ground = to_tile(road_to_image(check.truth_mm[None])[0])
    cv2.drawMarker(tile, tuple(ground), RED_BGR, cv2.MARKER_CROSS, 10, 2)
    if check.front_mm is not None:
        front = to_tile(road_to_image(check.front_mm[None])[0])
        cv2.drawMarker(tile, tuple(front), BLUE_BGR, cv2.MARKER_TILTED_CROSS, 10, 2)
    verdict = "no record" if check.status == "no record" else (
        f"{check.error_mm / 1000:.2f} m" if check.front_mm is not None else check.reason)
    cv2.putText(tile, f"{check.spot.frame} {check.spot.lane}: {verdict}", (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                (255, 255, 255), 1)
    return tile


def contact_sheet(checks: list[SpotCheck], calibration, records: pd.DataFrame, path: Path) -> None:
    """Every spot's tile, the localized footprint of its record drawn in, five to a row."""
    by_frame: dict[int, list[SpotCheck]] = {}
    for check in checks:
        by_frame.setdefault(check.spot.frame, []).append(check)
    tiles = []
    for index, frame in enumerate(iter_frames(VIDEO)):
        for check in by_frame.get(index, []):
            canvas = frame.copy()
            if check.front_mm is not None:
                row = records[(records.frame == index) & (records.track_id == check.track_id)].iloc[0]
                corners = np.array([[row[f"corner{i}_x_mm"], row[f"corner{i}_y_mm"]] for i in range(4)])
                polygon = calibration.road_to_image(corners)
                cv2.polylines(canvas, [np.round(polygon).astype(np.int32)], True, BLUE_BGR, 1)
            tiles.append(spot_tile(canvas, check, calibration.road_to_image))
        if index >= max(by_frame):
            break
    while len(tiles) % 5:
        tiles.append(np.zeros_like(tiles[0]))
    write_image(path, np.vstack([np.hstack(tiles[i:i + 5]) for i in range(0, len(tiles), 5)]))


@exit_on_error("experiments/real_video/highway_spot_check.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--calibration", type=Path, required=True, help="calibration.json written by highway.py")
    parser.add_argument("--records", type=Path, required=True, help="records.csv written by highway_localize.py")
    parser.add_argument("--truth", type=Path, default=TRUTH, help="the spot-truth YAML")
    parser.add_argument("--max-error-m", type=float, default=1.5)
    parser.add_argument("--out", type=Path, default=Path("outputs/highway_spots"))
    args = parser.parse_args()
    if not args.max_error_m > 0:
        raise DataError(f"--max-error-m must be positive, got {args.max_error_m}")
    truth = read_spot_truth(args.truth)
    calibration = read_calibration(args.calibration)
    if calibration.camera is None:
        raise DataError(f"{args.calibration}: no camera can be recovered from its homography")
    if not args.records.is_file():
        raise DataError(f"{args.records}: no such records file (run highway_localize.py first)")
    records = pd.read_csv(args.records)

    checks = [check_spot(s, truth, records, calibration.camera, args.max_error_m * 1000) for s in truth.spots]
    table = spot_table(checks)
    write_text(args.out / "spot_check.csv", table.to_csv(index=False))
    contact_sheet(checks, calibration, records, args.out / "spots.png")
    localized = table[table.status == "localized"]
    shown = table[["frame", "lane", "body", "colour", "front_y_px", "truth_y_m", "truth_sigma_along_m", "track_id",
                   "status", "error_along_m", "error_across_m", "error_m", "within"]]
    lines = [
        "# The highway clip against its hand-read fronts",
        "",
        f"{len(table)} spots in {table.frame.nunique()} frames ({(table.lane == 'left').sum()} in the left lane, "
        f"{(table.lane == 'right').sum()} in the right); {len(localized)} matched a localized record; "
        f"**{int(table.within.sum())} of {len(table)} within {args.max_error_m:g} m**"
        + (f"; error of the localized: median {localized.error_m.median():.2f} m, worst {localized.error_m.max():.2f}"
           f" m, along the road median {localized.error_along_m.median():+.2f} m" if len(localized) else "") + ".",
        "",
        markdown_table(shown.round(2)),
        "",
        "![the spots](spots.png) hand reading and its ground point red, the localized footprint and front blue.",
    ]
    write_text(args.out / "report.md", "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
