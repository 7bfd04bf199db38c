"""A hand count of the vehicles crossing a real video, and the measured tracks matched to it: does `tracks.csv` have
a speed for every vehicle that crossed the view?

A crossing is read by hand as the first frame in which a vehicle covers an image row, and its lane. A measured track
crosses that row when the front of its footprint (its path's point itself where that is its box's bottom: its nearest
end), moving as its constant-velocity fit of the road path says, reaches
the road line under the row: the frame is extrapolated where the track ends before the row. Crossings and tracks of
one lane are matched one to one, nearest in time first, within a tolerance.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.data.text import read_yaml
from vehloc.errors import DataError
from vehloc.geometry.pipeline.track_speed import SpeedStatus
from vehloc.geometry.projective import ProjectiveTransform


@dataclass(frozen=True)
class Crossing:
    """One vehicle through the counting row: the first frame it covers the row, its lane by eye."""

    frame: int
    lane: str


@dataclass(frozen=True)
class CrossingCount:
    """A hand count: the image row counted at, the first frame counted from, the crossings."""

    row_px: float
    first_frame: int
    crossings: tuple[Crossing, ...]


@dataclass(frozen=True)
class CrossingMatch:
    """A crossing and the measured track matched to it (None: no measured track of its lane crossed near its frame),
    the frame that track crosses the row, its speed (km/h)."""

    crossing: Crossing
    track_id: int | None
    track_frame: float
    speed_kmh: float


def read_crossings(path: str | Path) -> CrossingCount:
    """The hand count at `path` (YAML: row_px, first_frame, crossings of frame and lane); DataError naming the file."""
    data = read_yaml(path, DataError)
    if not isinstance(data, dict) or not {"row_px", "first_frame", "crossings"} <= set(data):
        raise DataError(f"{path}: needs row_px, first_frame and crossings")
    crossings = []
    for index, item in enumerate(data["crossings"]):
        if not isinstance(item, dict) or not {"frame", "lane"} <= set(item):
            raise DataError(f"{path}: crossing {index} needs a frame and a lane")
        crossings.append(Crossing(int(item["frame"]), str(item["lane"])))
    return CrossingCount(float(data["row_px"]), int(data["first_frame"]), tuple(crossings))


def row_road_y_mm(road_to_image: ProjectiveTransform, row_px: float, x_mm: float) -> float:
    """The road Y (mm) at road X `x_mm` of the image row `row_px`: the row's road line there."""
    a, b, c = road_to_image.inverse.map_lines(np.array([[0.0, 1.0, -row_px]]))[0]
    return float(-(a * x_mm + c) / b)


def track_crossing_frame(frames: np.ndarray, y_mm: np.ndarray, length_mm: float, row_y_mm: float) -> float:
    """The frame at which the front of a footprint `length_mm` long, its centre moving along the road as the
    least-squares line of `y_mm` over `frames` says, reaches `row_y_mm` (NaN for a path that does not move)."""
    slope, intercept = np.polyfit(np.asarray(frames, float), np.asarray(y_mm, float), 1)
    if slope == 0.0:
        return float("nan")
    front_offset_mm = np.sign(slope) * length_mm / 2.0
    return float((row_y_mm - front_offset_mm - intercept) / slope)


def match_crossings(count: CrossingCount, tracks: pd.DataFrame, trajectories: pd.DataFrame,
                    road_to_image: ProjectiveTransform, lane_of: Callable[[float], str],
                    tolerance_frames: float) -> list[CrossingMatch]:
    """Each crossing with the measured track of `tracks.csv` (and its `trajectories.csv` points used) matched to it;
    a track's lane is `lane_of` the road X of its point nearest in time to its crossing (its median road X where it
    does not cross)."""
    candidates = []
    for track in tracks[tracks.status == SpeedStatus.MEASURED].itertuples():
        path = trajectories[(trajectories.track_id == track.track_id) & trajectories.used]
        if len(path) < 2:
            continue
        x_mm = float(path.x_mm.median())
        length_mm = 0.0 if getattr(track, "reference", "") == "box_bottom" else float(track.length_mm)
        frame = track_crossing_frame(path.frame.to_numpy(), path.y_mm.to_numpy(), length_mm,
                                     row_road_y_mm(road_to_image, count.row_px, x_mm))
        if np.isfinite(frame):  # its lane where it crosses: a vehicle changing lanes is counted in the one it is in
            x_mm = float(path.x_mm.to_numpy()[np.argmin(np.abs(path.frame.to_numpy() - frame))])
        candidates.append((int(track.track_id), lane_of(x_mm), frame, float(track.speed_kmh)))
    pairs = sorted((abs(frame - c.frame), i, j) for i, c in enumerate(count.crossings)
                   for j, (_, lane, frame, _) in enumerate(candidates)
                   if lane == c.lane and abs(frame - c.frame) <= tolerance_frames)
    taken_crossings: dict[int, int] = {}
    taken_tracks: set[int] = set()
    for _, i, j in pairs:
        if i not in taken_crossings and j not in taken_tracks:
            taken_crossings[i] = j
            taken_tracks.add(j)
    matches = []
    for i, crossing in enumerate(count.crossings):
        if i in taken_crossings:
            track_id, _, frame, speed = candidates[taken_crossings[i]]
            matches.append(CrossingMatch(crossing, track_id, frame, speed))
        else:
            matches.append(CrossingMatch(crossing, None, float("nan"), float("nan")))
    return matches
