"""The speed benchmark's scoring (BrnoCompSpeed's `code/eval.py`), re-implemented on its own rules: the system's
cars pre-filtered (points 10 px from the image's border, more than 5 points, every point between the lane-dividing
lines and none in an invalid lane, at least 6 points between the first and last measurement lines), each car's
crossings of the first and last measurement lines interpolated in space and time from its 6 points nearest each
line, its speed as the median over 5-frame steps (`median` mode, the benchmark's default) or between the two
crossings (`full`), each true car matched to the system car of its lane whose last crossing is nearest in time
(within 0.2 s); then the speed errors of the matched valid cars, recall, false positives and precision, and the
error of the distances the truth measured towards the first vanishing point."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.brno import focal_and_road_plane, road_plane_points
from vehloc.geometry.pipeline.brno_files import BrnoCar, BrnoResults, GroundTruth

SAFE_BORDER_OFFSET_PX = 10
MIN_POINTS = 5
MIN_POINTS_BETWEEN_LINES = 6
MAX_TIME_DIFF_S = 0.2
INTERSECTION_POINTS = 6
MEDIAN_STEP_FRAMES = 5
MODES = ("median", "full")
BENCHMARK_SIZE_PX = (1920, 1080)


@dataclass(frozen=True)
class ScoredCar:
    """A system car that passed the pre-filters and crossed both lines: its speeds, lane and crossing times."""

    car_id: int
    speed_full_kmh: float
    speed_median_kmh: float
    lane: int
    first_time_s: float
    last_time_s: float


@dataclass(frozen=True)
class Match:
    """A true car and the system car matched to it (None when none was)."""

    truth_id: int
    true_speed_kmh: float
    valid: bool
    lane: int
    last_time_s: float
    car_id: int | None = None
    speed_kmh: float | None = None

    @property
    def error_kmh(self) -> float | None:
        return None if self.speed_kmh is None else self.speed_kmh - self.true_speed_kmh


@dataclass(frozen=True)
class SpeedScore:
    """A video's score: the matches, the false positives (and the cars whose crossings could not be computed among
    them), the distances' errors (m) and the system cars kept by the pre-filters."""

    matches: tuple[Match, ...]
    false_positives: int
    failed_crossings: int
    distance_errors_m: tuple[float, ...]
    distance_truths_m: tuple[float, ...]
    kept_cars: int

    @property
    def errors_kmh(self) -> np.ndarray:
        return np.array([abs(m.error_kmh) for m in self.matches if m.speed_kmh is not None and m.valid])

    @property
    def relative_errors_percent(self) -> np.ndarray:
        return np.array([abs(m.error_kmh) / m.true_speed_kmh * 100 for m in self.matches
                         if m.speed_kmh is not None and m.valid])

    @property
    def recall(self) -> float:
        valid = [m for m in self.matches if m.valid]
        return sum(m.speed_kmh is not None for m in valid) / len(valid) if valid else float("nan")

    @property
    def precision(self) -> float:
        true_positives = len({m.car_id for m in self.matches if m.car_id is not None})
        total = true_positives + self.false_positives
        return true_positives / total if total else float("nan")

    def summary(self) -> dict[str, float]:
        """Mean / median / 95th percentile / worst speed error (km/h and %), recall, precision, counts and the
        distance error (mean m and %)."""
        errors, relative = self.errors_kmh, self.relative_errors_percent
        distances = np.abs(np.array(self.distance_errors_m))
        stats = {}
        for name, values in (("kmh", errors), ("percent", relative)):
            empty = len(values) == 0
            stats |= {f"mean_error_{name}": np.nan if empty else float(np.mean(values)),
                      f"median_error_{name}": np.nan if empty else float(np.median(values)),
                      f"p95_error_{name}": np.nan if empty else float(np.percentile(values, 95)),
                      f"worst_error_{name}": np.nan if empty else float(np.max(values))}
        return stats | {
            "measured": float(len(errors)), "true_cars": float(sum(m.valid for m in self.matches)),
            "recall": self.recall, "precision": self.precision, "false_positives": float(self.false_positives),
            "mean_distance_error_m": float(np.mean(distances)) if len(distances) else np.nan,
            "mean_distance_error_percent": float(np.mean(distances / np.array(self.distance_truths_m)) * 100)
            if len(distances) else np.nan,
        }


def lane_of(point_px: np.ndarray, lane_lines: np.ndarray) -> int | None:
    """The lane between two consecutive lane-dividing lines that holds the image point (`getLaneForPoint`)."""
    p = np.append(np.asarray(point_px, dtype=float)[:2], 1.0)
    for i in range(len(lane_lines) - 1):
        if (p @ lane_lines[i]) * (p @ lane_lines[i + 1]) * (lane_lines[i][:2] @ lane_lines[i + 1][:2]) <= 0:
            return i
    return None


def between_lines(point_px: np.ndarray, first: np.ndarray, last: np.ndarray) -> bool:
    p = np.append(np.asarray(point_px, dtype=float)[:2], 1.0)
    return (p @ first) * (p @ last) * (first[:2] @ last[:2]) <= 0


def prefilter(results: BrnoResults, truth: GroundTruth, image_size_px: tuple[int, int]) -> list[BrnoCar]:
    """The system's cars the scorer keeps, their points near the image's border dropped (`prefilterData`)."""
    width, height = image_size_px
    latest_s = max(car.crossing_times_s[-1] for car in truth.cars)
    kept = []
    for car in results.cars:
        if len(car.frames) == 0 or car.frames[0] / truth.fps >= latest_s:
            continue
        x, y = car.points_px[:, 0], car.points_px[:, 1]
        inside = ((x > SAFE_BORDER_OFFSET_PX) & (x < width - SAFE_BORDER_OFFSET_PX) & (y > SAFE_BORDER_OFFSET_PX)
                  & (y < height - SAFE_BORDER_OFFSET_PX))
        car = BrnoCar(car.car_id, car.frames[inside], car.points_px[inside])
        if len(car.frames) <= MIN_POINTS:
            continue
        lanes = [lane_of(p, truth.lane_lines) for p in car.points_px]
        if None in lanes or any(lane in truth.invalid_lanes for lane in lanes):
            continue
        between = sum(0 <= p[0] <= width and 0 <= p[1] <= height
                      and between_lines(p, truth.measurement_lines[0], truth.measurement_lines[-1]) for p in car.points_px)
        if between >= MIN_POINTS_BETWEEN_LINES:
            kept.append(car)
    return kept


def _regression(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Slope and intercept of the least-squares line y = slope x + intercept (`scipy.stats.linregress`); NaN when
    every x is the same."""
    dx = x - x.mean()
    spread = float(dx @ dx)
    if spread == 0.0:
        return float("nan"), float("nan")
    slope = float(dx @ (y - y.mean())) / spread
    return slope, float(y.mean() - slope * x.mean())


def crossing(line: np.ndarray, points_px: np.ndarray, frames: np.ndarray) -> tuple[np.ndarray, float]:
    """Where (px) and at which frame a path crosses an image line, from its points nearest the line
    (`getCarTimeAndSpatialIntersection`): a straight line through them in the image, and frames linear in the
    distance along it."""
    homogeneous = np.column_stack([points_px, np.ones(len(points_px))])
    distance = np.abs(homogeneous @ line) / np.linalg.norm(line[:2])
    nearest = np.argsort(distance, kind="stable")[:INTERSECTION_POINTS]
    slope, intercept = _regression(points_px[nearest, 0], points_px[nearest, 1])
    path_line = np.array([slope, -1.0, intercept])
    spatial = np.cross(path_line, line)
    spatial = spatial / spatial[-1]
    origin = np.cross(path_line, [0.0, 1.0, 0.0])
    origin = origin / origin[-1]
    a, b = path_line[0], path_line[1]
    projected = []
    for point in homogeneous[nearest]:  # `pointToLineProjection`
        c = point[0] * b - point[1] * a
        foot = np.cross(path_line, [-b, a, c])
        projected.append(foot / foot[-1])
    along = np.array([np.linalg.norm(origin - p) for p in projected])
    time_slope, time_intercept = _regression(along, frames[nearest].astype(float))
    return spatial[:2], time_slope * float(np.linalg.norm(spatial - origin)) + time_intercept


def score_speeds(results: BrnoResults, truth: GroundTruth, image_size_px: tuple[int, int] = BENCHMARK_SIZE_PX,
                 mode: str = "median") -> SpeedScore:
    """Score a system's results against a video's truth with the benchmark's rules (see the module)."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    calibration = results.calibration
    focal, plane = focal_and_road_plane(np.array(calibration.vp1_px), np.array(calibration.vp2_px),
                                        np.array(calibration.pp_px))

    def metres(points_px: np.ndarray) -> np.ndarray:
        return calibration.scale * road_plane_points(points_px, focal, plane, np.array(calibration.pp_px))

    scored, failed = [], 0
    for car in prefilter(results, truth, image_size_px):
        start_px, start_frame = crossing(truth.measurement_lines[-1], car.points_px, car.frames)
        end_px, end_frame = crossing(truth.measurement_lines[0], car.points_px, car.frames)
        end_lane, start_lane = lane_of(end_px, truth.lane_lines), lane_of(start_px, truth.lane_lines)
        values = np.concatenate([end_px, start_px, [start_frame, end_frame]])
        if not np.all(np.isfinite(values)) or end_lane is None or start_lane is None or start_frame == end_frame:
            failed += 1
            continue
        ends = metres(np.array([start_px, end_px]))
        full = float(np.linalg.norm(ends[0] - ends[1])) / (abs(end_frame - start_frame) / truth.fps) * 3.6
        points = metres(car.points_px)
        steps = [np.linalg.norm(points[i] - points[i + MEDIAN_STEP_FRAMES])
                 / (abs(car.frames[i] - car.frames[i + MEDIAN_STEP_FRAMES]) / truth.fps) * 3.6
                 for i in range(len(points) - MEDIAN_STEP_FRAMES)]
        scored.append(ScoredCar(car.car_id, full, float(np.median(steps)), end_lane, start_frame / truth.fps,
                                end_frame / truth.fps))
    matches = []
    for true_car in truth.cars:
        last_s = true_car.crossing_times_s[-1]
        lane = min(true_car.lanes) if true_car.lanes else -1
        candidates = sorted((c for c in scored if c.lane in true_car.lanes), key=lambda c: abs(c.last_time_s - last_s))
        match = Match(true_car.car_id, true_car.speed_kmh, true_car.valid, lane, last_s)
        if candidates and abs(candidates[0].last_time_s - last_s) < MAX_TIME_DIFF_S:
            best = candidates[0]
            match = Match(true_car.car_id, true_car.speed_kmh, true_car.valid, lane, last_s, best.car_id,
                          best.speed_median_kmh if mode == "median" else best.speed_full_kmh)
        matches.append(match)
    last_times = [c.crossing_times_s[-1] for c in truth.cars]
    matched = {m.car_id for m in matches if m.car_id is not None}
    false_positives = failed + sum(1 for c in scored if min(last_times) <= c.last_time_s < max(last_times)
                                   and c.car_id not in matched)
    towards_vp1 = [d for d in truth.distances if d.to_vp1]
    distance_errors = []
    for d in towards_vp1:
        ends = metres(np.array([d.p1_px, d.p2_px]))
        distance_errors.append(float(np.linalg.norm(ends[0] - ends[1])) - d.distance_m)
    return SpeedScore(tuple(matches), false_positives, failed, tuple(distance_errors),
                      tuple(d.distance_m for d in towards_vp1), len(scored))
