"""Hand-read spot truth for a real video: each vehicle's front ground line read off a frame, and the localized
records checked against it.

A spot is a pixel read by hand: the middle of a vehicle's front where it gives way to the shadow below it, the
bumper's lowest edge. That edge stands above the road by a clearance (by body type), so its ground line is the
homography's road point of the pixel scaled towards the camera's foot (`lowered_points_mm`). A record matches a
spot when its box holds the pixel; its front is the middle of its footprint's end nearest the camera.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.data.text import read_yaml
from vehloc.errors import DataError
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.keypoints import lowered_points_mm
from vehloc.geometry.pipeline.localize import Status

SPOT_FIELDS = ("frame", "lane", "body", "colour", "front_x_px", "front_y_px")
LANES = ("left", "right")
BOX_MARGIN_PX = 2.0


@dataclass(frozen=True)
class Spot:
    """One vehicle read by hand in one frame: its lane and body by eye, its front's lower edge (px)."""

    frame: int
    lane: str
    body: str
    colour: str
    front_px: tuple[float, float]


@dataclass(frozen=True)
class SpotTruth:
    """A spot-truth file: its spots, the bumper clearance by body type and the 1-sigmas of clearance and reading."""

    spots: tuple[Spot, ...]
    clearance_mm: dict[str, float]
    clearance_sigma_mm: float
    reading_sigma_px: float


@dataclass(frozen=True)
class SpotCheck:
    """One spot against the records: its ground point (mm) and that point's 1-sigma along the road, the matching
    record's track, status and reason, its front (mm, None when not localized) and the errors (mm)."""

    spot: Spot
    truth_mm: np.ndarray
    truth_sigma_along_mm: float
    track_id: int | None
    status: str
    reason: str
    front_mm: np.ndarray | None
    error_along_mm: float
    error_across_mm: float
    error_mm: float
    within: bool


def read_spot_truth(path: str | Path) -> SpotTruth:
    """The spot-truth YAML at `path`, checked field by field (DataError naming the file and the field)."""
    data = read_yaml(path, DataError)
    if not isinstance(data, dict):
        raise DataError(f"{path}: not a mapping of clearance_mm, clearance_sigma_mm, reading_sigma_px, spots")
    for key in ("clearance_mm", "clearance_sigma_mm", "reading_sigma_px", "spots"):
        if key not in data:
            raise DataError(f"{path}: missing `{key}`")
    clearance = {str(k): float(v) for k, v in data["clearance_mm"].items()}
    spots = []
    for index, item in enumerate(data["spots"]):
        missing = [f for f in SPOT_FIELDS if f not in item]
        if missing:
            raise DataError(f"{path}: spot {index} lacks {', '.join(missing)}")
        if item["lane"] not in LANES:
            raise DataError(f"{path}: spot {index} has lane {item['lane']!r}, not one of {LANES}")
        if item["body"] not in clearance:
            raise DataError(f"{path}: spot {index} has body {item['body']!r}, not one of {sorted(clearance)}")
        spots.append(Spot(int(item["frame"]), str(item["lane"]), str(item["body"]), str(item["colour"]),
                          (float(item["front_x_px"]), float(item["front_y_px"]))))
    if not spots:
        raise DataError(f"{path}: no spots")
    return SpotTruth(tuple(spots), clearance, float(data["clearance_sigma_mm"]), float(data["reading_sigma_px"]))


def ground_point_mm(front_px: tuple[float, float], clearance_mm: float, camera: PinholeCamera) -> np.ndarray:
    """The road point (mm) below an image point `clearance_mm` above the road."""
    road_mm = camera.image_to_road(np.array([front_px]))
    return lowered_points_mm(road_mm, clearance_mm, camera.centre_mm)[0]


def ground_point_sigma_along_mm(spot: Spot, truth: SpotTruth, camera: PinholeCamera) -> float:
    """The 1-sigma along the road (Y) of a spot's ground point: its reading's and its clearance's, in quadrature."""
    x, y = spot.front_px
    h = truth.clearance_mm[spot.body]
    d_reading = ground_point_mm((x, y + truth.reading_sigma_px), h, camera) - ground_point_mm(
        (x, y - truth.reading_sigma_px), h, camera)
    d_clearance = ground_point_mm((x, y), h + truth.clearance_sigma_mm, camera) - ground_point_mm(
        (x, y), h - truth.clearance_sigma_mm, camera)
    return float(np.hypot(d_reading[1], d_clearance[1]) / 2.0)


def front_mm(corners_mm: np.ndarray, camera_foot_mm: np.ndarray) -> np.ndarray:
    """The middle of a footprint's end nearest the camera's foot: of its two shorter edges, the nearer one."""
    corners = np.asarray(corners_mm, dtype=float).reshape(4, 2)
    edges = [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
    ends = sorted(edges, key=lambda e: np.linalg.norm(e[1] - e[0]))[:2]
    middles = [(a + b) / 2.0 for a, b in ends]
    return min(middles, key=lambda m: np.linalg.norm(m - camera_foot_mm))


def matching_record(records: pd.DataFrame, spot: Spot) -> pd.Series | None:
    """The record of the spot's frame whose box holds its pixel (within `BOX_MARGIN_PX`), a localized one first,
    then the one whose box bottom is nearest the pixel's row; None when no box holds it."""
    x, y = spot.front_px
    frame = records[records.frame == spot.frame]
    holds = frame[(frame.box_x0_px - BOX_MARGIN_PX <= x) & (x <= frame.box_x1_px + BOX_MARGIN_PX)
                  & (frame.box_y0_px - BOX_MARGIN_PX <= y) & (y <= frame.box_y1_px + BOX_MARGIN_PX)]
    if holds.empty:
        return None
    order = holds.assign(_not_localized=holds.status != Status.LOCALIZED, _gap=(holds.box_y1_px - y).abs())
    return holds.loc[order.sort_values(["_not_localized", "_gap"]).index[0]]


def check_spot(spot: Spot, truth: SpotTruth, records: pd.DataFrame, camera: PinholeCamera,
               max_error_mm: float) -> SpotCheck:
    """One spot against the records (`vehloc-localize`'s records.csv columns)."""
    truth_mm = ground_point_mm(spot.front_px, truth.clearance_mm[spot.body], camera)
    sigma = ground_point_sigma_along_mm(spot, truth, camera)
    record = matching_record(records, spot)
    if record is None:
        return SpotCheck(spot, truth_mm, sigma, None, "no record", "no record's box holds the spot", None,
                         np.nan, np.nan, np.nan, False)
    track = int(record.track_id)
    if record.status != Status.LOCALIZED:
        return SpotCheck(spot, truth_mm, sigma, track, str(record.status), str(record.reason_code), None,
                         np.nan, np.nan, np.nan, False)
    corners = np.array([[record[f"corner{i}_x_mm"], record[f"corner{i}_y_mm"]] for i in range(4)])
    front = front_mm(corners, camera.centre_mm[:2])
    error = front - truth_mm
    distance = float(np.hypot(*error))
    return SpotCheck(spot, truth_mm, sigma, track, Status.LOCALIZED.value, str(record.method), front, float(error[1]),
                     float(error[0]), distance, distance <= max_error_mm)


def spot_table(checks: list[SpotCheck]) -> pd.DataFrame:
    """One row per spot: where it was read, its ground point, the record that matched it and the errors (m)."""
    rows = []
    for c in checks:
        rows.append({
            "frame": c.spot.frame, "lane": c.spot.lane, "body": c.spot.body, "colour": c.spot.colour,
            "front_x_px": c.spot.front_px[0], "front_y_px": c.spot.front_px[1],
            "truth_x_m": c.truth_mm[0] / 1000, "truth_y_m": c.truth_mm[1] / 1000,
            "truth_sigma_along_m": c.truth_sigma_along_mm / 1000,
            "track_id": c.track_id, "status": c.status, "reason": c.reason,
            "front_x_m": np.nan if c.front_mm is None else c.front_mm[0] / 1000,
            "front_y_m": np.nan if c.front_mm is None else c.front_mm[1] / 1000,
            "error_along_m": c.error_along_mm / 1000, "error_across_m": c.error_across_mm / 1000,
            "error_m": c.error_mm / 1000, "within": c.within,
        })
    return pd.DataFrame(rows)
