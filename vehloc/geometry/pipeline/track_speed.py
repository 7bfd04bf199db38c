"""Every vehicle's path and speed, once its track is removed (or the video ends): its voted model, its reference
point on the road in every frame the frame's edge does not cut it (the footprint centre at which the model's shape
has the box's top where the vehicle's box has it, `vehloc.geometry.box_reference`), the constant-velocity speed
through them with its 1-sigma, and its lane. The vote's `candidates` likeliest models are each measured so, for
`vehloc.geometry.pipeline.model_choice` to check the vote against the vehicle's boxes once the video's vehicles are
known."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np

from vehloc.config import check_choice, check_range, params_from_config
from vehloc.geometry.box_reference import box_height_excess, box_mismatch, centre_from_box
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.motion import path_heading
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.pipeline.tracker import VehicleTrack
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.speed import SpeedFit, fit_speed
from vehloc.geometry.uncertainty import road_mm_per_px
from vehloc.infer.classifier import VehicleClassifier

REFERENCES = ("shape_top", "shape_bottom", "box_bottom")
"""A vehicle's reference point: the footprint centre from its box's top or bottom and its model's shape, or the road
point under its box's bottom as it is."""


@dataclass(frozen=True)
class StitchParams:
    """When two measured tracks are one vehicle (`vehloc.geometry.pipeline.stitching`; `stitch` of
    `conf/localize/speed/default.yaml`)."""

    max_gap_s: float
    max_offset_mm: float
    max_speed_difference_fraction: float
    ends_points: int

    def __post_init__(self) -> None:
        check_range("max_gap_s", self.max_gap_s, 0.0)
        check_range("max_offset_mm", self.max_offset_mm, 0.0)
        check_range("max_speed_difference_fraction", self.max_speed_difference_fraction, 0.0)
        check_range("ends_points", self.ends_points, 1)


@dataclass(frozen=True)
class SpeedParams:
    """How tracks become speeds (`conf/localize/speed/default.yaml`)."""

    enabled: bool
    reference: str
    min_points: int
    min_distance_mm: float
    lane_lines_x_mm: tuple[float, ...] | None
    lane_gap_mm: float
    max_box_mismatch: float
    edge_inset_px: float
    candidates: int
    reference_min_probability: float
    min_reference_vehicles: int
    min_excess_sigma: float
    max_heading_gap_deg: float
    unknown_by_box_bottom: bool
    unknown_max_held_fraction: float
    unknown_held_within_mm: float
    unknown_max_sigma_fraction: float
    stitch: StitchParams

    def __post_init__(self) -> None:
        check_range("candidates", self.candidates, 1)
        check_range("max_heading_gap_deg", self.max_heading_gap_deg, 0.0, 90.0, low_open=True)
        check_range("reference_min_probability", self.reference_min_probability, 0.0, 1.0)
        check_range("min_reference_vehicles", self.min_reference_vehicles, 1)
        check_range("min_excess_sigma", self.min_excess_sigma, 0.0, 1.0, low_open=True)
        check_range("edge_inset_px", self.edge_inset_px, -2.0, 2.0)
        check_range("unknown_max_held_fraction", self.unknown_max_held_fraction, 0.0, 1.0)
        check_range("unknown_held_within_mm", self.unknown_held_within_mm, 0.0, low_open=True)
        check_range("unknown_max_sigma_fraction", self.unknown_max_sigma_fraction, 0.0, low_open=True)
        check_range("max_box_mismatch", self.max_box_mismatch, 0.0, low_open=True)
        check_choice("reference", self.reference, REFERENCES)
        check_range("min_points", self.min_points, 3)
        check_range("min_distance_mm", self.min_distance_mm, 0.0)
        check_range("lane_gap_mm", self.lane_gap_mm, 0.0, low_open=True)
        if self.lane_lines_x_mm is not None and list(self.lane_lines_x_mm) != sorted(self.lane_lines_x_mm):
            raise ValueError(f"lane_lines_x_mm must be in increasing order, got {list(self.lane_lines_x_mm)}")

    @classmethod
    def from_config(cls, **overrides: object) -> SpeedParams:
        """The settings of `conf/localize/speed/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/speed/default.yaml", overrides)


FIT_COLUMNS = ("speed_kmh", "sigma_kmh", "fit_sigma_kmh", "scale_sigma_kmh", "heading_deg", "distance_m")
"""The columns of `tracks.csv` a vehicle's speed fills (empty without one): the `SpeedFit` fields of those names."""


class SpeedStatus(StrEnum):
    MEASURED = "measured"
    NOT_MEASURED = "not measured"


@dataclass(frozen=True)
class VehiclePath:
    """A vehicle's reference points: the frames, the road points (N, 2) mm, their pixels (N, 2) and the vehicle's box
    at each (N, 4: x0, y0, x1, y1 px, exclusive)."""

    frames: np.ndarray
    points_mm: np.ndarray
    points_px: np.ndarray
    boxes_px: np.ndarray


@dataclass(frozen=True)
class ModelCandidate:
    """One of a vehicle's likeliest models by its track's vote: the model, the vote's probability, the path and speed
    its shape gives the vehicle's boxes, and how much taller those boxes are than the shape's (the median over the
    path's frames of (box height - shape's box height) / shape's: the cast shadow and blur under every vehicle of a
    video; NaN without a path)."""

    model_id: int
    make: str
    model: str
    probability: float
    dims_mm: tuple[float, float, float]
    path: VehiclePath
    speed: SpeedFit | NotPlaced
    box_height_excess: float = float("nan")


class ModelSource(StrEnum):
    VOTE = "vote"
    BOX_HEIGHT = "vote and box height"
    UNKNOWN = "none: no likely model's size"


@dataclass(frozen=True)
class VehicleSpeed:
    """One vehicle of a video: its track, frames, model, path, speed (or why none) and lane; the vote's likeliest
    models each measured (`candidates`, the vote's first model first) and where the model came from (`model_source`)."""

    track_id: int
    first_frame: int
    last_frame: int
    fps: float
    path: VehiclePath
    speed: SpeedFit | NotPlaced
    model_id: int | None = None
    make: str = ""
    model: str = ""
    probability: float | None = None
    dims_mm: tuple[float, float, float] | None = None
    lane: int | None = None
    candidates: tuple[ModelCandidate, ...] = ()
    model_source: ModelSource = ModelSource.VOTE
    reference: str = "shape_top"
    """Where its path's points are on it (`REFERENCES`): the road point under its box's bottom for a vehicle none of
    the likely models fits (`ModelSource.UNKNOWN`)."""
    joined_track_ids: tuple[int, ...] = ()
    """The tracks it was joined from, in order, where two or more were one vehicle (`stitching`); empty otherwise."""
    seen_frames: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    """The frames its track was followed in (its box seen, cut by the frame's edge or not, its own or merged with
    another vehicle's, or the box of another's blob it was hidden in): where its path has no used point, its steady
    motion is reported at those of them whose box holds it."""
    seen_boxes_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), int))
    """(N, 4) the box at each of `seen_frames` (x0, y0, x1, y1 px, exclusive)."""

    def with_candidate(self, candidate: ModelCandidate, source: ModelSource) -> VehicleSpeed:
        """The vehicle as `candidate`'s model, path and speed make it."""
        return replace(self, model_id=candidate.model_id, make=candidate.make, model=candidate.model,
                       probability=candidate.probability, dims_mm=candidate.dims_mm, path=candidate.path,
                       speed=candidate.speed, model_source=source)

    @property
    def status(self) -> SpeedStatus:
        return SpeedStatus.MEASURED if isinstance(self.speed, SpeedFit) else SpeedStatus.NOT_MEASURED

    @property
    def lateral_mm(self) -> float:
        """The path's median position across the road (world X, mm); NaN without points."""
        return float(np.median(self.path.points_mm[:, 0])) if len(self.path.frames) else float("nan")

    def row(self) -> dict[str, object]:
        """Its row of `tracks.csv`."""
        fit = self.speed if isinstance(self.speed, SpeedFit) else None
        failure = self.speed if isinstance(self.speed, NotPlaced) else None
        return {
            "track_id": self.track_id, "first_frame": self.first_frame, "last_frame": self.last_frame,
            "first_time_s": self.first_frame / self.fps, "last_time_s": self.last_frame / self.fps, "lane": self.lane,
            "model_id": self.model_id, "make": self.make, "model": self.model, "probability": self.probability,
            "model_source": self.model_source.value, "reference": self.reference,
            "joined_track_ids": " ".join(str(i) for i in self.joined_track_ids),
            "voted_model_id": self.candidates[0].model_id if self.candidates else self.model_id,
            **dict(zip(("length_mm", "width_mm", "height_mm"), self.dims_mm or (None, None, None))),
            **{name: None if fit is None else getattr(fit, name) for name in FIT_COLUMNS},
            "points": len(self.path.frames) if fit is None else fit.points,
            "points_dropped": None if fit is None else fit.dropped,
            "status": self.status.value,
            "reason_code": "" if failure is None else failure.code.value, "reason": "" if failure is None else failure.message,
        }

    @property
    def used(self) -> np.ndarray:
        """(N,) bool: the path's points its speed was measured on (all of them without a speed)."""
        return self.speed.used if isinstance(self.speed, SpeedFit) else np.ones(len(self.path.frames), bool)

    def reported(self, road_to_image: ProjectiveTransform) -> tuple[np.ndarray, np.ndarray]:
        """Where it was in every frame it was followed in, as its results report it: the frames (N,) and road points
        (N, 2) mm, its measured reference point where its speed used one, else where its steady motion (its speed's
        fit) put it, where the box followed at that frame holds that point's pixel (`road_to_image`): the frames its box
        was cut by the frame's edge, held another vehicle too (their blobs merged, or it was hidden in the other's),
        or strayed from its motion; not those where its track had gone on to another vehicle. Only its used points
        without a speed."""
        frames, points = self.path.frames[self.used], self.path.points_mm[self.used]
        if not isinstance(self.speed, SpeedFit):
            return frames, points
        gaps = ~np.isin(self.seen_frames, frames)
        steady = self.speed.positions_mm(self.seen_frames[gaps] / self.fps)
        pixels = road_to_image(steady) if len(steady) else np.zeros((0, 2))
        boxes = self.seen_boxes_px[gaps]
        held = ((pixels[:, 0] >= boxes[:, 0]) & (pixels[:, 0] < boxes[:, 2]) & (pixels[:, 1] >= boxes[:, 1])
                & (pixels[:, 1] < boxes[:, 3]))
        all_frames = np.concatenate([frames, self.seen_frames[gaps][held]])
        order = np.argsort(all_frames, kind="stable")
        return all_frames[order], np.concatenate([points.reshape(-1, 2), steady[held]])[order]

    def trajectory_rows(self, road_to_image: ProjectiveTransform) -> list[dict[str, object]]:
        """Its rows of `trajectories.csv`: one per frame of its path, saying whether its speed used it, and one per
        frame its steady motion is reported at instead (`predicted`; `reported`), mapped to pixels by
        `road_to_image`."""
        rows = [{"track_id": self.track_id, "frame": int(frame), "time_s": frame / self.fps, "x_mm": point[0],
                 "y_mm": point[1], "x_px": pixel[0], "y_px": pixel[1], "used": bool(used), "predicted": False}
                for frame, point, pixel, used in zip(self.path.frames, self.path.points_mm, self.path.points_px,
                                                     self.used)]
        frames, points = self.reported(road_to_image)
        gaps = ~np.isin(frames, self.path.frames[self.used])
        pixels = road_to_image(points[gaps]) if gaps.any() else np.zeros((0, 2))
        rows += [{"track_id": self.track_id, "frame": int(frame), "time_s": frame / self.fps, "x_mm": point[0],
                  "y_mm": point[1], "x_px": pixel[0], "y_px": pixel[1], "used": False, "predicted": True}
                 for frame, point, pixel in zip(frames[gaps], points[gaps], pixels)]
        return sorted(rows, key=lambda row: (row["frame"], row["predicted"]))


def seen_boxes(track: VehicleTrack) -> dict[str, np.ndarray]:
    """`VehicleSpeed`'s `seen_frames` and `seen_boxes_px` of a track: the frames it was seen or hidden in, in order,
    and their boxes."""
    pairs = sorted(zip(track.frames + track.hidden_frames, track.boxes + track.hidden_boxes), key=lambda p: p[0])
    return {"seen_frames": np.array([f for f, _ in pairs], dtype=int).reshape(-1),
            "seen_boxes_px": np.array([[b.x0, b.y0, b.x1, b.y1] for _, b in pairs], dtype=int).reshape(-1, 4)}


EMPTY_PATH = VehiclePath(np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 4), int))


class TrackSpeeds:
    """Turns removed tracks into `VehicleSpeed`s: the classifier names each track's likeliest models (track voting),
    whose shapes take its box's edge to its footprint centre (boxes found on frames shrunk `box_block_px` times)."""

    def __init__(self, classifier: VehicleClassifier, calibration: CameraCalibration, params: SpeedParams,
                 fps: float, heading_jitter_px: float, box_block_px: float) -> None:
        self.classifier = classifier
        self.calibration = calibration
        self.params = params
        self.fps = fps
        self.heading_jitter_px = heading_jitter_px
        self.box_block_px = box_block_px

    def measure(self, track: VehicleTrack) -> VehicleSpeed:
        """The vehicle of a finished track, as the vote's likeliest model makes it, with every candidate measured."""
        frames = np.array(track.ground_frames, dtype=int)
        bottoms = np.array(track.ground_points_mm, dtype=float).reshape(-1, 2)
        vehicle = VehicleSpeed(track.track_id, track.frames[0], track.last_frame, self.fps, EMPTY_PATH,
                               NotPlaced(ReasonCode.TOUCHES_EDGE, "the frame's edge cut it in every frame"),
                               **seen_boxes(track))
        if track.votes.empty:
            return replace(vehicle, speed=NotPlaced(ReasonCode.TOO_SMALL_TO_CLASSIFY,
                                                    "its box was never big enough to classify"))
        probabilities = track.votes.vote(self.classifier)
        likeliest = self.classifier.predictions(probabilities[None], top_k=self.params.candidates)[0].top_k
        likeliest = likeliest[:1] + tuple(c for c in likeliest[1:] if c.probability > 0.0)
        heading = path_heading(bottoms, frames.astype(float), self.params.min_distance_mm,
                               self.calibration.road_to_image, self.heading_jitter_px) if len(frames) else None
        if len(frames) and heading is None:
            vehicle = replace(vehicle, speed=NotPlaced(ReasonCode.PATH_TOO_SHORT,
                                                       "its path is too short to tell its direction"))
        boxes = dict(zip(track.frames, track.boxes))
        candidates = tuple(self.candidate(c.model_id, c.probability, frames, bottoms, boxes,
                                          None if heading is None else heading.heading_deg, vehicle.speed)
                           for c in likeliest)
        vehicle = replace(vehicle, reference=self.params.reference, candidates=candidates)
        unknown = all(isinstance(c.speed, NotPlaced) and c.speed.code == ReasonCode.BOX_NOT_MODEL_SIZE
                      for c in candidates)
        if unknown and self.params.unknown_by_box_bottom:
            return self.unknown(vehicle, frames, bottoms, boxes)
        return vehicle.with_candidate(candidates[0], ModelSource.VOTE)

    def unknown(self, vehicle: VehicleSpeed, frames: np.ndarray, bottoms: np.ndarray, boxes: dict) -> VehicleSpeed:
        """A vehicle none of whose likely models is the size of its boxes (a truck, a bus: a model its classifier
        does not know), measured by the road point under its box's bottom in every frame (its nearest end's ground
        line, wherever along it the vehicle's centre is) and given no model."""
        path = self.path(frames, bottoms, boxes)
        return replace(vehicle, path=path, speed=self.refit(path), reference="box_bottom",
                       model_source=ModelSource.UNKNOWN)

    def at_centre(self, vehicle: VehicleSpeed, length_mm: float) -> VehicleSpeed:
        """A vehicle measured by its box's bottom as one `length_mm` long measured at its footprint centre would be:
        each point moved half the length along its motion away from the camera (its box's bottom is its nearest end's
        ground line) and its speed measured again; as it is without a camera or a speed, or where the moved path has
        none."""
        camera = self.calibration.camera
        if camera is None or not isinstance(vehicle.speed, SpeedFit) or not len(vehicle.path.frames):
            return vehicle
        direction = vehicle.speed.velocity_mm_s / np.linalg.norm(vehicle.speed.velocity_mm_s)
        points = vehicle.path.points_mm
        towards_camera = np.where((camera.centre_mm[:2] - points) @ direction >= 0.0, 1.0, -1.0)
        moved = points - towards_camera[:, None] * (length_mm / 2.0) * direction
        path = replace(vehicle.path, points_mm=moved, points_px=self.calibration.road_to_image(moved))
        speed = self.refit(path)
        return replace(vehicle, path=path, speed=speed) if isinstance(speed, SpeedFit) else vehicle

    def candidate(self, model_id: int, probability: float, frames: np.ndarray, bottoms: np.ndarray, boxes: dict,
                  heading_deg: float | None, failure: NotPlaced) -> ModelCandidate:
        """The vehicle measured as `model_id`: its path and speed (`failure` where there is no heading to measure
        along) and how much taller its boxes are than the model's shape."""
        spec = next(c for c in self.classifier.classes if c.model_id == model_id)
        candidate = ModelCandidate(model_id, spec.make, spec.model, probability,
                                   tuple(float(v) for v in spec.dims_mm), EMPTY_PATH, failure)
        if heading_deg is None:
            return candidate
        points, excess = bottoms, float("nan")
        if self.params.reference != "box_bottom":
            kept, centres, excesses = self.centres(model_id, frames, bottoms, boxes, heading_deg)
            if not kept.any() and np.isfinite(centres).all(axis=1).any():
                return replace(candidate, speed=NotPlaced(ReasonCode.BOX_NOT_MODEL_SIZE, (
                    f"none of its {len(frames)} boxes is within {self.params.max_box_mismatch:.0%} of the {spec.model}'s "
                    "size there (speed.max_box_mismatch): a vehicle its classifier does not know (a truck, a bus) "
                    "or vehicles merged into one blob")))
            frames, points = frames[kept], centres[kept].reshape(-1, 2)
            excess = float(np.median(excesses[kept])) if kept.any() else float("nan")
        path = self.path(frames, points, boxes)
        return replace(candidate, path=path, speed=self.refit(path), box_height_excess=excess)

    def centres(self, model_id: int, frames: np.ndarray, bottoms: np.ndarray, boxes: dict,
                heading_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Which frames are kept, their footprint centres (N, 2 mm) from the boxes' edge and the model's shape
        (`centre_from_box`) and how much taller each box is than the shape's there (`box_height_excess`; NaN where no
        centre was found): a frame is kept where the centre was found and its box is the size of the model's there
        (`max_box_mismatch`)."""
        camera, edge = self.calibration.camera, self.params.reference.removeprefix("shape_")
        shape = self.classifier.metadata.shape_of(model_id)
        centres = np.full((len(frames), 2), np.nan)
        excesses = np.full(len(frames), np.nan)
        kept = np.zeros(len(frames), bool)
        for f, (frame, bottom) in enumerate(zip(frames, bottoms)):
            centre = centre_from_box(camera, shape, boxes[frame], heading_deg, bottom, edge, self.box_block_px,
                                     self.params.edge_inset_px)
            if not isinstance(centre, NotPlaced):
                centres[f] = centre
                excesses[f] = box_height_excess(camera, shape, boxes[frame], centre, heading_deg)
                kept[f] = box_mismatch(camera, shape, boxes[frame], centre, heading_deg,
                                       self.box_block_px) <= self.params.max_box_mismatch
        return kept, centres, excesses

    def path(self, frames: np.ndarray, points_mm: np.ndarray, boxes: dict) -> VehiclePath:
        """The path of road points `points_mm` at `frames`, with their pixels and the vehicle's box at each."""
        pixels = self.calibration.road_to_image(points_mm) if len(points_mm) else np.zeros((0, 2))
        return VehiclePath(frames, points_mm, pixels,
                           np.array([[b.x0, b.y0, b.x1, b.y1] for b in (boxes[f] for f in frames)], int).reshape(-1, 4))

    def refit(self, path: VehiclePath) -> SpeedFit | NotPlaced:
        """The speed through a path (a candidate's, or one joined from two tracks' used points)."""
        return fit_speed(path.points_mm, path.frames / self.fps, self.scale_sigma_fraction(path.points_mm),
                         self.params.min_points, self.params.min_distance_mm)

    def scale_sigma_fraction(self, points_mm: np.ndarray) -> float:
        """The calibration's relative error over a path: its reprojection error at the path's middle, in mm on the
        road, at both ends, over the path's length, and its scale's own (an automatic calibration's), in quadrature."""
        scale = self.calibration.scale_sigma_fraction
        if len(points_mm) < 2:
            return scale
        length_mm = float(np.linalg.norm(points_mm[-1] - points_mm[0]))
        if length_mm <= 0.0:
            return scale
        middle = points_mm[len(points_mm) // 2]
        position_mm = self.calibration.rms_reprojection_px * road_mm_per_px(self.calibration.road_to_image, middle)
        return float(np.hypot(np.sqrt(2.0) * position_mm / length_mm, scale))


def assign_lanes(vehicles: Sequence[VehicleSpeed], params: SpeedParams) -> list[VehicleSpeed]:
    """Each vehicle's lane, numbered from the road's left (smallest X): between the site's lane lines where
    `lane_lines_x_mm` gives them (None outside them), else the clusters of the measured vehicles' positions across the
    road (a gap of `lane_gap_mm` between neighbours starts a lane); a vehicle without a speed (a fragment, a far car
    seen a few frames, whose positions would fill the gaps) or measured by its box's bottom (`ModelSource.UNKNOWN`:
    not its centre) takes the lane of the nearest measured one within
    `lane_gap_mm`, else none."""
    lateral = np.array([v.lateral_mm for v in vehicles], dtype=float)
    lanes: list[int | None] = [None] * len(vehicles)
    if params.lane_lines_x_mm is not None:
        lines = np.asarray(params.lane_lines_x_mm, dtype=float)
        for i, x in enumerate(lateral):
            index = int(np.searchsorted(lines, x))
            lanes[i] = index - 1 if np.isfinite(x) and 0 < index < len(lines) else None
    else:
        measured = [i for i in np.argsort(lateral) if np.isfinite(lateral[i])
                    and vehicles[i].status == SpeedStatus.MEASURED and vehicles[i].model_source != ModelSource.UNKNOWN]
        lane = 0
        for previous, current in zip([None] + measured[:-1], measured):
            if previous is not None and lateral[current] - lateral[previous] > params.lane_gap_mm:
                lane += 1
            lanes[current] = lane
        for i in (i for i in range(len(vehicles)) if lanes[i] is None and np.isfinite(lateral[i]) and measured):
            nearest = min(measured, key=lambda j: abs(lateral[j] - lateral[i]))
            lanes[i] = lanes[nearest] if abs(lateral[nearest] - lateral[i]) <= params.lane_gap_mm else None
    return [replace(v, lane=lane) for v, lane in zip(vehicles, lanes)]


MIN_TRAFFIC_VEHICLES = 3
"""The measured vehicles a video needs for the direction of its traffic to be told."""


def along_traffic(vehicles: Sequence[VehicleSpeed], params: SpeedParams) -> list[VehicleSpeed]:
    """The vehicles, those whose steady motion is more than `max_heading_gap_deg` off the direction of the video's
    traffic (the axis of its measured vehicles' headings, either way along it: their doubled angles' mean, taken again
    without those off it) not measured: a track whose boxes were of two vehicles in two lanes, its path across them. Left as they are with fewer
    than `MIN_TRAFFIC_VEHICLES` measured."""
    headings = np.radians([v.speed.heading_deg for v in vehicles if isinstance(v.speed, SpeedFit)])
    if len(headings) < MIN_TRAFFIC_VEHICLES:
        return list(vehicles)
    axis = traffic_axis(headings, np.ones(len(headings), bool))
    axis = traffic_axis(headings, axis_gap_deg(headings, axis) <= params.max_heading_gap_deg)
    result = []
    for v in vehicles:
        if isinstance(v.speed, SpeedFit):
            gap_deg = float(axis_gap_deg(np.radians([v.speed.heading_deg]), axis)[0])
            if gap_deg > params.max_heading_gap_deg:
                v = replace(v, speed=NotPlaced(ReasonCode.PATH_ACROSS_TRAFFIC, (
                    f"its path is {gap_deg:.1f} deg off the traffic's direction, more than {params.max_heading_gap_deg:g} "
                    f"(speed.max_heading_gap_deg): its boxes were of two vehicles, in two lanes")))
        result.append(v)
    return result


def traffic_axis(headings_rad: np.ndarray, kept: np.ndarray) -> float:
    """The axis (rad, either way along it) of the `kept` headings: their doubled angles' mean, halved (all of them
    where none is kept)."""
    doubled = 2 * (headings_rad[kept] if kept.any() else headings_rad)
    return float(0.5 * np.arctan2(np.mean(np.sin(doubled)), np.mean(np.cos(doubled))))


def axis_gap_deg(headings_rad: np.ndarray, axis_rad: float) -> np.ndarray:
    """How far each heading is off an axis, either way along it (deg, 0-90)."""
    return np.degrees(np.abs(np.angle(np.exp(2j * (headings_rad - axis_rad)))) / 2)
