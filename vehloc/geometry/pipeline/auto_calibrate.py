"""A camera calibrated by the vehicles it sees (`vehloc-calibrate mode=auto`): one pass over the video gathers the
straight paths of points on the moving vehicles, their straight edges and their tracks (with the crops the
classifier votes on); the two vanishing points give the focal length and the road's orientation, and each vehicle
whose model is recognised gives the camera's height at which that model's shape has its box (the scale). Too little
traffic, or none moving straight, is a `FailedEstimate` saying so, never a wrong calibration."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from vehloc.config import check_choice, check_range, params_from_config
from vehloc.data.dimension_error import expected_dims_mm
from vehloc.data.shapes import VehicleShape
from vehloc.geometry.auto_calibration import (
    RobustScale,
    camera_at_height,
    camera_from_horizon,
    camera_from_vanishing_points,
    combine_heights,
    focal_from_vanishing_points,
    height_from_sides,
    horizon_through,
)
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.outcome import FailedEstimate
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.speed_files import benchmark_calibration
from vehloc.geometry.pipeline.tracker import StoppedVehicleTracker, VehicleTrack
from vehloc.geometry.pipeline.video import VideoFrames
from vehloc.geometry.roi import VehicleRoiExtractor
from vehloc.geometry.traffic_evidence import (
    FeatureParams,
    FeatureTracks,
    Outline,
    across_candidates,
    edge_segments,
    road_line_candidates,
    sure_outline,
)
from vehloc.geometry.vanishing import Segments, VanishingPoint, find_vanishing_point, refine_point
from vehloc.infer.classifier import VehicleClassifier

SCALE_SOURCES = ("recognised", "mean_size")
RECOGNISED_SIZES = ("expected", "voted")
ROAD_LINES_AGREEMENT = 0.9


@dataclass(frozen=True)
class AutoCalibrationParams:
    """The settings of `conf/calibrate/auto_calibration/default.yaml`."""

    principal_point_px: tuple[float, float] | None
    focal_px: float | None
    max_frames: int
    scale_source: str
    recognised_size: str
    max_features: int
    detect_every_frames: int
    min_feature_distance_px: float
    max_backward_error_px: float
    min_track_frames: int
    min_track_extent_px: float
    max_track_rms_px: float
    motion_max_angle_deg: float
    edges_every_frames: int
    edge_min_length_px: float
    edge_min_angle_to_vp1_deg: float
    edge_max_slope_deg: float
    edge_max_angle_deg: float
    min_support: float
    road_lines: bool
    road_line_min_length_fraction: float
    road_line_search_deg: float
    road_line_max_angle_deg: float
    min_road_lines: int
    bootstrap_samples: int
    nominal_height_mm: float
    outline_every_frames: int
    outline_margin_px: int
    outline_inset_px: float
    views_per_vehicle: int
    min_views: int
    min_box_height_px: int
    max_bottom_gap_fraction: float
    min_vehicles: int

    def __post_init__(self) -> None:
        check_range("max_frames", self.max_frames, 0)
        check_choice("scale_source", self.scale_source, SCALE_SOURCES)
        check_choice("recognised_size", self.recognised_size, RECOGNISED_SIZES)
        check_range("max_features", self.max_features, 1, 10_000)
        check_range("detect_every_frames", self.detect_every_frames, 1, 1000)
        check_range("min_feature_distance_px", self.min_feature_distance_px, 1.0, 1000.0)
        check_range("max_backward_error_px", self.max_backward_error_px, 0.0, 10.0, low_open=True)
        check_range("min_track_frames", self.min_track_frames, 3, 10_000)
        check_range("min_track_extent_px", self.min_track_extent_px, 1.0)
        check_range("max_track_rms_px", self.max_track_rms_px, 0.0, 10.0, low_open=True)
        check_range("motion_max_angle_deg", self.motion_max_angle_deg, 0.0, 45.0, low_open=True)
        check_range("edges_every_frames", self.edges_every_frames, 1, 1000)
        check_range("edge_min_length_px", self.edge_min_length_px, 2.0, 10_000.0)
        check_range("edge_min_angle_to_vp1_deg", self.edge_min_angle_to_vp1_deg, 0.0, 45.0)
        check_range("edge_max_slope_deg", self.edge_max_slope_deg, 1.0, 89.0)
        check_range("edge_max_angle_deg", self.edge_max_angle_deg, 0.0, 45.0, low_open=True)
        check_range("min_support", self.min_support, 0.0, 1.0, low_open=True)
        check_range("road_line_min_length_fraction", self.road_line_min_length_fraction, 0.0, 1.0, low_open=True)
        check_range("road_line_search_deg", self.road_line_search_deg, 0.0, 45.0, low_open=True)
        check_range("road_line_max_angle_deg", self.road_line_max_angle_deg, 0.0, 45.0, low_open=True)
        check_range("min_road_lines", self.min_road_lines, 2, 10_000)
        check_range("bootstrap_samples", self.bootstrap_samples, 2, 10_000)
        check_range("nominal_height_mm", self.nominal_height_mm, 0.0, 1e6, low_open=True)
        check_range("outline_every_frames", self.outline_every_frames, 1, 1000)
        check_range("outline_margin_px", self.outline_margin_px, 0, 100)
        check_range("outline_inset_px", self.outline_inset_px, 0.0, 2.0)
        check_range("views_per_vehicle", self.views_per_vehicle, 1, 10_000)
        check_range("min_views", self.min_views, 1, self.views_per_vehicle)
        check_range("min_box_height_px", self.min_box_height_px, 4, 10_000)
        check_range("max_bottom_gap_fraction", self.max_bottom_gap_fraction, 0.0, low_open=True)
        check_range("min_vehicles", self.min_vehicles, 1, 100_000)
        if self.focal_px is not None:
            check_range("focal_px", self.focal_px, 0.0, 1e6, low_open=True)
        if self.principal_point_px is not None and len(self.principal_point_px) != 2:
            raise ValueError(f"principal_point_px must be [x, y] or null, got {list(self.principal_point_px)}")

    @classmethod
    def from_config(cls, **overrides: object) -> AutoCalibrationParams:
        return params_from_config(cls, "calibrate/auto_calibration/default.yaml", overrides)

    @property
    def features(self) -> FeatureParams:
        return FeatureParams(self.max_features, self.min_feature_distance_px, self.max_backward_error_px,
                             self.min_track_frames, self.min_track_extent_px, self.max_track_rms_px)


@dataclass(frozen=True)
class TrafficEvidence:
    """What one pass over a video gathered: the straight paths of points on the vehicles (as segments, and their
    points one a frame), their edges, their finished tracks (boxes and crops) with their outlines in some frames (by
    track id and frame), the frames read, the image size, the road without traffic, and where the video's decoding
    stopped short of its container's promise (`VideoFrames.early_end`)."""

    motion: Segments
    paths: tuple[np.ndarray, ...]
    edges: Segments
    tracks: tuple[VehicleTrack, ...]
    outlines: dict[int, dict[int, Outline]]
    frames: int
    image_size_px: tuple[int, int]
    background_bgr: np.ndarray
    early_end: str | None = None


def moving_mask(extractor: VehicleRoiExtractor, shape: tuple[int, int]) -> np.ndarray:
    """The last frame's vehicle pixels at full size, grown by two pixels (the features on their outlines)."""
    mask = cv2.resize(extractor.last_mask, (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST)
    return cv2.dilate(mask, np.ones((5, 5), np.uint8))


def collect_traffic(video: str | Path, params: AutoCalibrationParams, settings: LocalizeSettings | None = None,
                    progress: bool | None = None) -> TrafficEvidence:
    """One pass over `video`: the background model's vehicle boxes tracked (each track keeping its largest views for
    the vote, and every `outline_every_frames`-th frame where the frame's edge does not cut it and it is tall enough,
    the outline of its full-resolution silhouette without cast shadow), points followed on the moving vehicles and
    their edges found (MediaError when it cannot be read). A progress bar with `progress`; None: where stderr is a
    terminal."""
    settings = settings or LocalizeSettings.compose()
    video_frames = VideoFrames(video)
    info = video_frames.info
    total = video_frames.frames_to_read(params.max_frames or None)
    extractor = VehicleRoiExtractor(settings.roi)
    tracker = StoppedVehicleTracker(settings.pipeline.vote_frames, settings.tracker, "largest", 1.0 / settings.roi.scale)
    features = FeatureTracks(params.features)
    edges: list[Segments] = []
    finished: list[VehicleTrack] = []
    outlines: dict[int, dict[int, Outline]] = {}
    frames = 0
    for index, frame in enumerate(tqdm(video_frames, total=total, desc="frames", unit="frame",
                                       disable=None if progress is None else not progress)):
        if total is not None and index >= total:
            break
        frames += 1
        update = tracker.update(extractor.apply(frame), index, frame.shape[0])
        finished.extend(update.removed)
        outline_due = index % params.outline_every_frames == 0
        for track in update.seen:
            cut = track.box.touches_border(info.width_px, info.height_px, settings.pipeline.border_margin_px)
            track.votes.add(frame, track.box, cut)
            if outline_due and not cut and track.box.height_px >= params.min_box_height_px:
                roi = track.box.grown(params.outline_margin_px, info.width_px, info.height_px)
                outline = sure_outline(extractor.foreground(roi), roi, params.outline_inset_px)
                if outline is not None:
                    outlines.setdefault(track.track_id, {})[index] = outline
        if extractor.last_mask is None:
            continue
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        mask = moving_mask(extractor, gray.shape)
        features.update(gray, mask, index % params.detect_every_frames == 0)
        if index % params.edges_every_frames == 0:
            edges.append(edge_segments(gray, mask, params.edge_min_length_px))
    finished.extend(tracker.tracks)
    background = extractor.background.astype(np.uint8) if extractor.background is not None else np.zeros(
        (info.height_px, info.width_px, 3), np.uint8)
    motion = features.finish()
    return TrafficEvidence(motion, tuple(features.straight_paths), Segments.join(edges), tuple(finished), outlines,
                           frames, (info.width_px, info.height_px), background, video_frames.early_end)


@dataclass(frozen=True)
class VehicleModel:
    """The model a vehicle is taken for: its shape, its name and how unsure the classifier is of its size (relative
    1-sigma)."""

    shape: VehicleShape
    label: str
    model_id: int | None
    size_doubt: float


ModelOfTrack = Callable[[VehicleTrack], VehicleModel | None]
"""Which model a finished track is taken for (None: it cannot be told)."""


def size_of(dims_mm: np.ndarray) -> np.ndarray:
    """A vehicle's linear size: the cube root of its length x width x height."""
    return np.cbrt(np.prod(np.asarray(dims_mm, dtype=float), axis=-1))


def recognised_models(classifier: VehicleClassifier, size: str) -> ModelOfTrack:
    """Each track's voted model (track voting over its largest views). `size` "voted": that model's shape as it is;
    "expected": stretched to the vote's expected dimensions (the probability-weighted top-k of the classifier's
    metadata, as Table 1's dimension error), so that a vote that cannot tell the vehicle apart gives it a size near
    its likely models' middle rather than the one that won by a hair. Its size doubt: the probability-weighted spread
    of the classes' sizes about the size given."""
    check_choice("size", size, RECOGNISED_SIZES)
    dims = classifier.metadata.dims_mm
    sizes = size_of(dims)

    def model_of(track: VehicleTrack) -> VehicleModel | None:
        if track.votes.empty:
            return None
        probabilities = track.votes.vote(classifier)
        top = int(np.argmax(probabilities))
        spec = classifier.classes[top]
        shape = classifier.metadata.shape_of(spec.model_id)
        if size == "expected":
            expected = expected_dims_mm(probabilities[None], dims, classifier.metadata.expected_top_k)[0]
            shape = VehicleShape(tuple(part * (expected / dims[top]) for part in shape.parts))
            given = float(size_of(expected))
        else:
            given = float(sizes[top])
        doubt = float(np.sqrt(probabilities @ (sizes / given - 1.0) ** 2))
        return VehicleModel(shape, spec.model, spec.model_id, doubt)

    return model_of


def mean_size_model(classifier: VehicleClassifier) -> ModelOfTrack:
    """Every track the catalog's mean car (Dubská's rule): the shape of the class nearest the mean dimensions,
    stretched to them; its doubt the classes' relative spread of size."""
    dims = classifier.metadata.dims_mm
    mean = dims.mean(axis=0)
    nearest = int(np.argmin(np.linalg.norm(dims / mean - 1.0, axis=1)))
    spec = classifier.classes[nearest]
    stretch = mean / dims[nearest]
    shape = VehicleShape(tuple(part * stretch for part in classifier.metadata.shape_of(spec.model_id).parts))
    sizes = size_of(dims)
    model = VehicleModel(shape, "catalog mean", None, float(np.std(sizes) / np.mean(sizes)))
    return lambda track: model


@dataclass(frozen=True)
class VehicleHeight:
    """One vehicle's estimate of the camera's height: its track, model, the views fitted and their median."""

    track_id: int
    model: str
    model_id: int | None
    views: int
    height_mm: float
    size_doubt: float
    heading_deg: float


def track_heading_deg(track: VehicleTrack, camera: PinholeCamera, border_margin_px: int) -> float | None:
    """+90 when the track's box bottoms move away from the camera along the road (+Y), -90 towards it; None when
    it moved too little to tell (under a tenth of its first box's height in the image)."""
    inside = [b for b in track.boxes if not b.touches_border(camera.width_px, camera.height_px, border_margin_px)]
    if len(inside) < 2:
        return None
    first, last = inside[0], inside[-1]
    if abs(last.y1 - first.y1) < 0.1 * first.height_px:
        return None
    bottoms = camera.image_to_road(np.array([[first.centre_px[0], first.y1 - 1.0], [last.centre_px[0], last.y1 - 1.0]]))
    return 90.0 if bottoms[1, 1] > bottoms[0, 1] else -90.0


def vehicle_height(track: VehicleTrack, outlines: dict[int, Outline], model: VehicleModel, camera: PinholeCamera,
                   params: AutoCalibrationParams, border_margin_px: int) -> VehicleHeight | None:
    """The camera's height by one vehicle: the median over up to `views_per_vehicle` of its outlines (spread over its
    track; those whose bottom is near the model's) of `height_from_sides`; None with fewer than `min_views`."""
    heading = track_heading_deg(track, camera, border_margin_px)
    if heading is None or len(outlines) < params.min_views:
        return None
    frames = sorted(outlines)
    picked = [frames[i] for i in np.unique(np.linspace(0, len(frames) - 1, params.views_per_vehicle).round().astype(int))]
    heights = []
    for frame in picked:
        outline = outlines[frame]
        fit = height_from_sides(camera, model.shape, outline.sides_px, outline.bottom_px, heading)
        if not isinstance(fit, FailedEstimate) and abs(fit.bottom_gap_px) <= params.max_bottom_gap_fraction * outline.height_px:
            heights.append(fit.height_mm)
    if len(heights) < params.min_views:
        return None
    return VehicleHeight(track.track_id, model.label, model.model_id, len(heights), float(np.median(heights)),
                         model.size_doubt, heading)


@dataclass(frozen=True)
class AutoCalibration:
    """A camera calibrated from traffic: the two vanishing points (homogeneous px) and their fits, the principal
    point, the focal length with its 1-sigma, the camera at the height the vehicles gave, the height's combination,
    each vehicle's estimate, and the segments the vanishing points were found on (`along`: the road's lines along the
    traffic where it has them (`vp1_source` "road lines"), else the paths of points on the vehicles ("motion");
    `across`: the vehicles' edges that may run across the road); the focal length's source, "vanishing points" or
    "given" (the lens's, `focal_px`: the second vanishing point then the camera's, from it and the horizon)."""

    vp1: VanishingPoint
    vp2: VanishingPoint
    pp_px: np.ndarray
    focal_px: float
    focal_sigma_px: float
    camera: PinholeCamera
    scale: RobustScale
    vehicles: tuple[VehicleHeight, ...]
    along: Segments
    across: Segments
    rms_reprojection_px: float
    scale_source: str
    vp1_source: str
    focal_source: str

    def camera_calibration(self, source: str) -> CameraCalibration:
        """The calibration as localization uses it, with the scale's relative 1-sigma."""
        return CameraCalibration(self.camera.road_to_image(), (self.camera.width_px, self.camera.height_px),
                                 self.camera, self.rms_reprojection_px, source, self.scale.sigma_fraction)

    def summary(self) -> dict[str, object]:
        """JSON-ready: the homography and what `read_calibration` needs, the camera, the figures' 1-sigmas, the
        vanishing points and the benchmark's block."""
        camera = self.camera
        forward = camera.R[2]
        tilt_deg = float(np.degrees(np.arcsin(-forward[2])))
        right = camera.R[0]
        roll_deg = float(np.degrees(np.arcsin(right[2])))
        summary: dict[str, object] = {
            "mode": "auto", "image_size_px": [camera.width_px, camera.height_px],
            "homography_world_mm_to_image_px": camera.road_to_image().normalised_matrix.tolist(),
            "rms_reprojection_px": self.rms_reprojection_px,
            "scale_sigma_fraction": self.scale.sigma_fraction,
            "focal_px": self.focal_px, "focal_sigma_px": self.focal_sigma_px, "focal_source": self.focal_source,
            "camera_height_mm": self.scale.height_mm, "camera_height_sigma_mm": self.scale.sigma_mm,
            "camera_tilt_deg": tilt_deg, "camera_roll_deg": roll_deg,
            "camera_centre_mm": camera.centre_mm.tolist(),
            "principal_point_px": self.pp_px.tolist(),
            "vp1_px": self.vp1.point_px.tolist(), "vp2_px": self.vp2.point_px.tolist(),
            "vp1_rms_deg": self.vp1.rms_deg, "vp2_rms_deg": self.vp2.rms_deg,
            "vp1_source": self.vp1_source, "along_segments": len(self.along), "across_segments": len(self.across),
            "scale_source": self.scale_source, "vehicles_used": self.scale.vehicles,
            "height_sigma_spread_mm": self.scale.sigma_spread_mm,
            "height_sigma_classifier_mm": self.scale.sigma_classifier_mm,
        }
        block = benchmark_calibration(self.camera_calibration("automatic calibration"), [])
        summary["camera_calibration"] = block if isinstance(block, str) else block.to_json()
        return summary


def focal_sigma_px(along: Segments, across: Segments, vp1: VanishingPoint, vp2: VanishingPoint, pp_px: np.ndarray,
                   samples: int, seed: int = 0) -> float:
    """The focal length's 1-sigma: its spread over the vanishing points refined on resampled (bootstrap) consenting
    segments."""
    rng = np.random.default_rng(seed)
    inliers1, inliers2 = along.subset(vp1.inliers), across.subset(vp2.inliers)
    focals = []
    for _ in range(samples):
        one = refine_point(inliers1.subset(rng.integers(0, len(inliers1), len(inliers1))), vp1.point_h)
        two = refine_point(inliers2.subset(rng.integers(0, len(inliers2), len(inliers2))), vp2.point_h)
        focal = focal_from_vanishing_points(one, two, pp_px)
        if not isinstance(focal, FailedEstimate):
            focals.append(focal)
    return float(np.std(focals)) if len(focals) >= 2 else float("inf")


def along_rms_px(along: Segments, vp1: VanishingPoint) -> float:
    """How far, RMS over the consenting segments, a segment's ends are from the line through its middle and the first
    vanishing point (px)."""
    inliers = along.subset(vp1.inliers)
    return float(np.sqrt(np.average((inliers.sin_to(vp1.point_h) * inliers.weights / 2) ** 2)))


def agrees_with_motion(motion: Segments, motion_vp1: VanishingPoint, lines_vp1: VanishingPoint,
                       max_angle_deg: float) -> bool:
    """Whether the road lines' point is one the traffic's motion agrees with: the paths within `max_angle_deg` of it
    hold at least `ROAD_LINES_AGREEMENT` of the weight those of the motion's own point hold (lines of one lane line
    only, its dashes, meet anywhere along it)."""
    limit = np.sin(np.radians(max_angle_deg))
    own = motion.weights[motion.sin_to(motion_vp1.point_h) < limit].sum()
    theirs = motion.weights[motion.sin_to(lines_vp1.point_h) < limit].sum()
    return bool(theirs >= ROAD_LINES_AGREEMENT * own)


def auto_calibrate(evidence: TrafficEvidence, model_of: ModelOfTrack, params: AutoCalibrationParams,
                   border_margin_px: int) -> AutoCalibration | FailedEstimate:
    """The camera from the gathered traffic: a `FailedEstimate` saying why when no vehicle moved straight, the edges agree
    on no second vanishing point, or fewer than `min_vehicles` vehicles could be scaled."""
    width, height = evidence.image_size_px
    pp = np.array(params.principal_point_px if params.principal_point_px is not None
                  else ((width - 1) / 2, (height - 1) / 2), dtype=float)
    motion_vp1 = find_vanishing_point(evidence.motion, params.motion_max_angle_deg, params.min_support)
    if isinstance(motion_vp1, FailedEstimate):
        return FailedEstimate(f"no vehicle seen moving straight ({len(evidence.motion)} straight point paths): {motion_vp1}")
    along, vp1, vp1_source = evidence.motion, motion_vp1, "motion"
    if params.road_lines:
        lines = road_line_candidates(evidence.background_bgr, motion_vp1.point_h, params.road_line_min_length_fraction,
                                     params.road_line_search_deg)
        lines_vp1 = find_vanishing_point(lines, params.road_line_max_angle_deg, 0.5) if len(lines) >= params.min_road_lines \
            else FailedEstimate("too few road lines")
        if (isinstance(lines_vp1, VanishingPoint) and lines_vp1.inliers.sum() >= params.min_road_lines
                and agrees_with_motion(evidence.motion, motion_vp1, lines_vp1, params.motion_max_angle_deg)):
            along, vp1, vp1_source = lines, lines_vp1, "road lines"
    across = across_candidates(evidence.edges, vp1.point_h, params.edge_min_angle_to_vp1_deg, params.edge_max_slope_deg)
    vp2 = find_vanishing_point(across, params.edge_max_angle_deg, params.min_support)
    if isinstance(vp2, FailedEstimate):
        return FailedEstimate(f"the vehicles' edges across the road give no second vanishing point ({len(across)} edges): {vp2}")
    if params.focal_px is None:
        unit = camera_from_vanishing_points(vp1.point_h, vp2.point_h, pp, params.nominal_height_mm, (width, height))
        if isinstance(unit, FailedEstimate):
            return unit
        focal_sigma = focal_sigma_px(along, across, vp1, vp2, pp, params.bootstrap_samples)
    else:
        unit = camera_from_horizon(vp1.point_h, horizon_through(vp1.point_h, vp2.point_h), pp, params.focal_px,
                                   params.nominal_height_mm, (width, height))
        across_point = unit.K @ unit.R[:, 0]
        vp2, focal_sigma = replace(vp2, point_h=across_point / np.linalg.norm(across_point)), 0.0
    vehicles = []
    for track in evidence.tracks:
        outlines = evidence.outlines.get(track.track_id, {})
        model = model_of(track) if len(outlines) >= params.min_views else None
        if model is None:
            continue
        estimate = vehicle_height(track, outlines, model, unit, params, border_margin_px)
        if estimate is not None:
            vehicles.append(estimate)
    if len(vehicles) < params.min_vehicles:
        return FailedEstimate(f"{len(vehicles)} vehicle(s) could be scaled by their model, {params.min_vehicles} needed "
                        f"(min_vehicles; {len(evidence.tracks)} tracked)")
    scale = combine_heights(np.array([v.height_mm for v in vehicles]), np.array([v.size_doubt for v in vehicles]))
    camera = camera_at_height(unit, scale.height_mm)
    focal = float(unit.K[0, 0])
    return AutoCalibration(vp1, vp2, pp, focal, focal_sigma, camera, scale, tuple(vehicles), along, across,
                           along_rms_px(along, vp1), params.scale_source, vp1_source,
                           "vanishing points" if params.focal_px is None else "given")
