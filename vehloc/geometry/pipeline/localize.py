"""The localization pipeline over a video: vehicle ROIs and tracks, one classification per track, key
points and the paper's placement, the model fit, and a record per vehicle (when it stops, or every frame).

Per frame: the background model gives vehicle boxes, the tracker follows them (one `VehicleTrack` per vehicle,
removed once lost) and says when one stops, and each track keeps a few crops for its vote and its road path. When
a vehicle is to be localized its crops are classified together (track voting), the key points (plate, else wheels) place the box of the predicted model's
dimensions (the paper's method), the predicted model's shape is fitted to its silhouette from there (the
model fit; a moving vehicle points where it goes, so with `heading_from_motion` its heading is its recent
path's and the fit finds only its position), and each estimate gets its 1-sigma uncertainty. A stopped vehicle
with neither plate nor wheels found is fitted from its silhouette's lower outline instead (`fit_from_silhouette`);
a moving vehicle's key points whose box lies across its own path are not taken (`max_key_points_path_gap_deg`).
A vehicle cut by the frame's edge, whose fit does not explain its silhouette, or that moves along a path too
short or too irregular to tell its heading, or which way it goes (and shows no key points), is recorded as not
localized, with its reason code and sentence: a stage that cannot place a vehicle returns a `NotPlaced`, never an
exception that ends the video. After the classification a record is made from its `RecordInputs` alone (`record_of`),
which an observer of the `Localizer` receives, so a benchmark can make its records again with other settings.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.specs import VehicleSpec
from vehloc.errors import VehlocError
from vehloc.geometry.model_fit import best_start, fit_model
from vehloc.geometry.motion import PathHeading
from vehloc.geometry.placement import VehicleBox, direction_of, facing
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.road_shadow import refit_with_restarts
from vehloc.geometry.roi import Silhouette, VehicleRoiExtractor
from vehloc.geometry.silhouette_start import silhouette_start_headings_deg
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.keypoints import Placement
from vehloc.geometry.pipeline.key_points import KeyPointInputs, paper_estimate
from vehloc.geometry.pipeline.timing import StageClock
from vehloc.geometry.pipeline.settings import LocalizeSettings, PipelineParams
from vehloc.geometry.pipeline.tracker import StoppedVehicleTracker, VehicleTrack
from vehloc.geometry.pipeline.travel import Travel, track_travel
from vehloc.geometry.uncertainty import (
    Uncertainty,
    calibration_part,
    dimension_spread_mm,
    fitted_spread,
    paper_dimension_part,
    road_mm_per_px,
)
from vehloc.infer.classifier import VehicleClassifier
from vehloc.infer.metadata import ModelMetadata
from vehloc.infer.preprocess import MIN_SIDE_PX


class Status(StrEnum):
    """A record's outcome."""

    LOCALIZED = "localized"
    NOT_LOCALIZED = "not localized"


FIT_STARTS = {"key points": "paper's placement", "travel": "track's travel", "silhouette": "silhouette"}
"""Where a model fit starts (`Estimate.start`), and how a record's notes name it."""


def travel_start_box(nearest_mm: np.ndarray, camera_foot_mm: np.ndarray, length_mm: float, width_mm: float,
                     heading_deg: float) -> VehicleBox:
    """Where the model fit starts without key points: the road point under the box's bottom taken as the
    footprint's point nearest the camera, the centre half the footprint's extent beyond it along the line of
    sight from the camera's foot, the heading that of the track's travel."""
    sight = np.asarray(nearest_mm, dtype=float) - np.asarray(camera_foot_mm, dtype=float)
    sight = sight / np.linalg.norm(sight)
    forward = direction_of(heading_deg)
    left = np.array([-forward[1], forward[0]])
    depth_mm = length_mm / 2 * abs(sight @ forward) + width_mm / 2 * abs(sight @ left)
    return VehicleBox(np.asarray(nearest_mm, dtype=float) + depth_mm * sight, heading_deg, length_mm, width_mm)


@dataclass(frozen=True)
class Estimate:
    """One method's localization: the box on the road, the key point it stands on (paper's method), its
    1-sigma uncertainty, the silhouette overlap reached and where it started (model fit: `FIT_STARTS`)."""

    method: str
    box: VehicleBox
    key_point: str | None
    uncertainty: Uncertainty
    iou: float | None = None
    start: str = ""


@dataclass(frozen=True)
class VehicleRecord:
    """What the pipeline says of one vehicle at one frame: its status; when not localized, the code of why
    (`reason_code`) and the sentence (`reason`); for a localized one, `notes` on how (where the fit started, a
    heading from the path, a fit not reported)."""

    track_id: int
    frame: int
    box_px: Box
    status: Status
    reason_code: ReasonCode | None = None
    reason: str = ""
    notes: str = ""
    model_id: int | None = None
    make: str = ""
    model: str = ""
    probability: float | None = None
    dims_mm: tuple[float, float, float] | None = None
    estimates: tuple[Estimate, ...] = ()

    def estimate(self, method: str) -> Estimate | None:
        return next((e for e in self.estimates if e.method == method), None)

    def rows(self) -> list[dict[str, object]]:
        """Flat table rows: one per estimate, or one saying why there is none."""
        base: dict[str, object] = {
            "track_id": self.track_id, "frame": self.frame, "status": self.status.value,
            "reason_code": self.reason_code.value if self.reason_code else "", "reason": self.reason, "notes": self.notes,
            "box_x0_px": self.box_px.x0, "box_y0_px": self.box_px.y0, "box_x1_px": self.box_px.x1,
            "box_y1_px": self.box_px.y1, "model_id": self.model_id, "make": self.make, "model": self.model,
            "probability": self.probability,
            **dict(zip(("length_mm", "width_mm", "height_mm"), self.dims_mm or (None, None, None))),
        }
        if not self.estimates:
            return [base]
        rows = []
        for e in self.estimates:
            corners = e.box.corners_mm()
            rows.append(base | {
                "method": e.method, "key_point": e.key_point, "centre_x_mm": e.box.centre_mm[0],
                "centre_y_mm": e.box.centre_mm[1], "heading_deg": e.box.heading_deg,
                **{f"corner{i}_{axis}_mm": corners[i, j] for i in range(4) for j, axis in enumerate("xy")},
                "sigma_position_mm": e.uncertainty.position_mm, "sigma_heading_deg": e.uncertainty.heading_deg,
                "iou": e.iou, "start": e.start,
            })
        return rows


class Localizer:
    """Feed it frames in order; it returns the records of the vehicles localized at each frame."""

    def __init__(
        self,
        classifier: VehicleClassifier,
        calibration: CameraCalibration,
        settings: LocalizeSettings | None = None,
        clock: StageClock | None = None,
        observe_inputs: Callable[[RecordInputs], None] | None = None,
    ) -> None:
        if calibration.camera is None:
            raise VehlocError(f"{calibration.source}: no pinhole camera can be recovered from this calibration")
        self.classifier = classifier
        self.calibration = calibration
        self.settings = settings = settings or LocalizeSettings.compose()
        self.params = settings.pipeline
        self.extractor = VehicleRoiExtractor(settings.roi)
        self.tracker = StoppedVehicleTracker(self.params.vote_frames, settings.tracker, self.params.vote_policy,
                                             1.0 / settings.roi.scale)
        self.speed_params = settings.speed
        self.clock = clock or StageClock()
        self.observe_inputs = observe_inputs
        self.removed: list[VehicleTrack] = []

    def process(self, frame_index: int, frame_bgr: np.ndarray) -> list[VehicleRecord]:
        """Feed one frame; the records of the vehicles localized at it."""
        height_px, width_px = frame_bgr.shape[:2]
        self.calibration.check_image_size(width_px, height_px, f"frame {frame_index}")
        with self.clock.stage("background"):
            boxes = self.extractor.apply(frame_bgr)
        with self.clock.stage("tracking"):
            update = self.tracker.update(boxes, frame_index, height_px)
            self.removed = update.removed
            for track in update.seen:
                cut = track.box.touches_border(width_px, height_px, self.params.border_margin_px)
                track.votes.add(frame_bgr, track.box, cut)
                if cut:
                    continue  # the frame cuts the vehicle: its box's bottom is not where it stands
                bottom = np.array([[track.box.centre_px[0], track.box.y1 - 1.0]])
                track.add_ground_point(self.calibration.road_to_image.inverse(bottom)[0], frame_index)
        due = update.seen if self.params.every_frame else update.stopped
        return [self.localize(track, frame_index, frame_bgr) for track in due]

    def finish(self) -> list[VehicleTrack]:
        """The end of the video: every track still held, removed (`removed` holds, after each frame, the tracks that
        frame removed)."""
        self.removed, self.tracker.tracks = self.tracker.tracks, []
        return self.removed

    def travel(self, track: VehicleTrack, frame_index: int) -> Travel:
        """The track's travel at this frame (`track_travel`): moving when `heading_from_motion` is on and the tracker
        does not find it still."""
        moving = self.params.heading_from_motion and not self.tracker.is_still(track)
        return track_travel(track, frame_index, moving, self.params, self.calibration.road_to_image,
                      self.calibration.camera.centre_mm[:2])

    def body_touches_border(self, box: Box, width_px: int, height_px: int) -> bool:
        """Whether the vehicle's own pixels (its silhouette without the shadow under it) reach within the margin of the
        frame's edge; a blob whose cast shadow alone reaches it holds the whole vehicle."""
        roi = box.enlarged(self.params.detector_roi_fraction, width_px, height_px)
        body = Box.tight(self.extractor.foreground(roi, box).trimmed())
        if body is None:
            return True
        return body.shifted(roi.x0, roi.y0).touches_border(width_px, height_px, self.params.border_margin_px)

    def localize(self, track: VehicleTrack, frame_index: int, frame_bgr: np.ndarray) -> VehicleRecord:
        """The record of one tracked vehicle at this frame."""
        box = track.box
        height_px, width_px = frame_bgr.shape[:2]
        if (box.touches_border(width_px, height_px, self.params.border_margin_px)
                and self.body_touches_border(box, width_px, height_px)):
            return not_localized(track, frame_index, NotPlaced(ReasonCode.TOUCHES_EDGE,
                                                               "the vehicle touches the frame's edge"))
        if track.votes.empty:
            return not_localized(track, frame_index, NotPlaced(
                ReasonCode.TOO_SMALL_TO_CLASSIFY, f"its box ({box.width_px}x{box.height_px} px) was never big enough "
                                                  f"to classify (at least {MIN_SIDE_PX} px a side)"))
        with self.clock.stage("classification"):
            probabilities = track.votes.vote(self.classifier)
        top1 = self.classifier.predictions(probabilities[None], top_k=1)[0].top1
        spec = next(c for c in self.classifier.classes if c.model_id == top1.model_id)
        record = VehicleRecord(track.track_id, frame_index, box, Status.LOCALIZED, model_id=top1.model_id,
                               make=top1.make, model=top1.model, probability=top1.probability,
                               dims_mm=tuple(float(v) for v in spec.dims_mm))
        roi = box.enlarged(self.params.detector_roi_fraction, width_px, height_px)
        went = self.travel(track, frame_index)
        came, motion, unclear = went.came_heading_deg, went.motion, went.unclear
        if motion is not None:
            record = replace(record, notes=f"heading from the track's path (sigma {motion.sigma_deg:.1f} deg)")
        shape = self.classifier.metadata.shape_of(spec.model_id)
        with self.clock.stage("key points"):
            silhouette = self.extractor.foreground(roi, box)
            key_points = KeyPointInputs(track.track_id, frame_index, roi.crop(frame_bgr), silhouette, roi,
                                        self.calibration, spec, shape, went.visible_end, came, motion)
            nearest_mm = track.ground_points_mm[-1] if track.ground_points_mm else None
            inputs = RecordInputs(record, key_points, probabilities, self.classifier.metadata, nearest_mm, unclear)
            if self.observe_inputs is not None:
                self.observe_inputs(inputs)
            placement = paper_estimate(key_points, self.settings.detectors, self.params.wheels_at_axles,
                                       self.params.max_key_points_path_gap_deg)
        return record_of(inputs, placement, self.settings, self.clock)


@dataclass(frozen=True, eq=False)
class RecordInputs:
    """What a classified vehicle's record is made from after the classification: the record so far (`classified`: its
    predicted model, and a note on a heading from its path), the key-point stage's inputs, the vote's probabilities
    over the classes of `metadata`, the road point under the box's bottom (None where none is known) and why its
    travel cannot place it (`unclear`). An observer given to the `Localizer` receives them, so the stages after the
    classification can be run again on them with other settings (`vehloc.benchmark.replay`)."""

    classified: VehicleRecord
    key_points: KeyPointInputs
    probabilities: np.ndarray
    metadata: ModelMetadata
    nearest_mm: np.ndarray | None
    unclear: NotPlaced | None


def record_of(inputs: RecordInputs, placement: Placement | NotPlaced, settings: LocalizeSettings,
              clock: StageClock | None = None) -> VehicleRecord:
    """The record made from the paper's `placement` (`paper_estimate` of `inputs.key_points`): its box, and the model
    fit started there; without one, the fit from the track's travel or the silhouette (`fit_starts`), or why the
    vehicle is not localized."""
    clock = clock or StageClock()
    record, points, params = inputs.classified, inputs.key_points, settings.pipeline
    if isinstance(placement, NotPlaced):
        if inputs.unclear is not None:
            return replace(record, status=Status.NOT_LOCALIZED, reason_code=inputs.unclear.code,
                           reason=joined(placement.message, inputs.unclear.message), notes="")
        kind, headings = fit_starts(inputs, params)
        if not headings:
            return replace(record, status=Status.NOT_LOCALIZED, reason_code=placement.code,
                           reason=placement.message, notes="")
        with clock.stage("model fit"):
            weights = fit_weights(points.silhouette, points.motion)
            starts = [start_box(inputs, heading, kind, weights, settings) for heading in headings]
            fit = fitted(starts, inputs, settings, kind)
        if fit.iou < params.min_fit_iou:
            return replace(record, status=Status.NOT_LOCALIZED, reason_code=ReasonCode.POOR_FIT,
                           reason=joined(placement.message, poor_fit(fit)), notes="")
        return replace(record, notes=joined(f"fit from the {FIT_STARTS[fit.start]} ({placement.message})",
                                            record.notes), estimates=(fit,))
    paper_box = placement.box
    estimates = [Estimate("paper", paper_box, placement.kind,
                          paper_uncertainty(inputs, paper_box, placement.kind, placement.baseline_mm, params))]
    if params.fit:
        with clock.stage("model fit"):
            fit = fitted([paper_box], inputs, settings)
        if fit.iou >= params.min_fit_iou:
            estimates.append(fit)
        else:
            record = replace(record, notes=joined(record.notes, poor_fit(fit)))
    return replace(record, estimates=tuple(estimates))


def fit_starts(inputs: RecordInputs, params: PipelineParams) -> tuple[str, list[float]]:
    """Where the model fit starts when no key points are found (`FIT_STARTS`) and the headings it starts from:
    a moving vehicle from its path's heading and a stopped one from its travel's (`fit_from_travel`, when it
    travelled far enough to tell), else a stopped one from its silhouette's principal road direction and its
    perpendicular (`fit_from_silhouette`); no heading without the fit, or when the road point under the box's
    bottom is unknown."""
    points = inputs.key_points
    if not (params.fit and inputs.nearest_mm is not None and np.all(np.isfinite(inputs.nearest_mm))):
        return "", []
    if params.fit_from_travel and points.came_deg is not None:
        return "travel", [points.came_deg if points.motion is None else points.motion.heading_deg]
    if not (params.fit_from_silhouette and points.motion is None):
        return "", []
    offset = np.array([points.roi.x0, points.roi.y0], dtype=float)
    return "silhouette", list(silhouette_start_headings_deg(points.silhouette.mask, offset,
                                                            points.calibration.road_to_image))


def start_box(inputs: RecordInputs, heading_deg: float, start: str, weights: np.ndarray,
              settings: LocalizeSettings) -> VehicleBox:
    """The box a fit without key points starts from: its footprint's nearest point the road point under the box's
    bottom (`travel_start_box`); from the silhouette, the best overlap of the boxes moved from there along the
    line of sight by `pipeline.silhouette_search_mm` (a shadow or a lost bumper moves the box's bottom)."""
    points = inputs.key_points
    camera, spec, nearest_mm = points.calibration.camera, points.spec, inputs.nearest_mm
    foot = camera.centre_mm[:2]
    box = travel_start_box(nearest_mm, foot, spec.length_mm, spec.width_mm, heading_deg)
    if start != "silhouette":
        return box
    sight = (nearest_mm - foot) / np.linalg.norm(nearest_mm - foot)
    low_mm, high_mm, step_mm = settings.pipeline.silhouette_search_mm
    candidates = [replace(box, centre_mm=box.centre_mm + offset * sight)
                  for offset in np.arange(low_mm, high_mm + step_mm / 2, step_mm)]
    return best_start(camera, weights, points.roi, points.shape, candidates, settings.fit.supersample_for(points.roi))


def calibration_part_of(calibration: CameraCalibration, box: VehicleBox, baseline_mm: float) -> tuple[float, float]:
    """The calibration's share of a box's 1-sigma uncertainty, over a baseline of `baseline_mm` on the road."""
    mm_per_px = road_mm_per_px(calibration.road_to_image, box.centre_mm)
    from_foot_mm = float(np.linalg.norm(box.centre_mm - calibration.camera.centre_mm[:2]))
    return calibration_part(calibration.rms_reprojection_px, mm_per_px, baseline_mm,
                            calibration.scale_sigma_fraction * from_foot_mm)


def paper_uncertainty(inputs: RecordInputs, box: VehicleBox, kind: str, baseline_mm: float,
                      params: PipelineParams) -> Uncertainty:
    """The paper's box's 1-sigma uncertainty: the probable models' dimensions' spread and the calibration's."""
    spread = dimension_spread_mm(inputs.probabilities, inputs.metadata.dims_mm, params.uncertainty_top_k)
    return Uncertainty.combined(paper_dimension_part(kind, spread),
                                calibration_part_of(inputs.key_points.calibration, box, baseline_mm))


def fitted(starts: list[VehicleBox], inputs: RecordInputs, settings: LocalizeSettings,
           start_kind: str = "key points") -> Estimate:
    """The predicted model's shape fitted to the silhouette's weights from each of `starts` (the paper's
    placement, or the starts without key points), the best overlap kept (with `pipeline.keep_start_after_shadow`,
    the best after each is refitted without the shadow), facing the way a stopped vehicle came
    when its track travelled far enough to tell (else both ways tried, the better overlap kept), its heading held
    at the path's when the vehicle moves; a vehicle without a path heading then refitted without the road's
    shadow around it (`fit.shadow_passes`, `refit_with_restarts`), its outline's pixels weighing the share of them
    it covers (`fit_weights`; where it meets its shadow, read against the shadowed road); its uncertainty from
    refitting the other probable models' shapes from the kept start to the same weights, and the path heading's
    own."""
    points, metadata, probabilities, pipeline = inputs.key_points, inputs.metadata, inputs.probabilities, settings.pipeline
    camera, silhouette, roi, came_deg, motion = (points.calibration.camera, points.silhouette, points.roi,
                                                 points.came_deg, points.motion)
    order = np.argsort(-probabilities, kind="stable")[: pipeline.uncertainty_top_k]
    candidates = [i for i in order if i == order[0] or probabilities[i] >= pipeline.uncertainty_min_probability]
    stopped_came_from = came_deg if came_deg is not None and motion is None else None

    def begin_at(start: VehicleBox, spec: VehicleSpec, facing_deg: float | None) -> VehicleBox:
        begin = VehicleBox(start.centre_mm, start.heading_deg if motion is None else motion.heading_deg,
                           spec.length_mm, spec.width_mm)
        return begin if facing_deg is None else facing(begin, facing_deg)

    predicted = metadata.classes[candidates[0]]
    params = settings.fit if stopped_came_from is None else replace(settings.fit, try_reversed=False)
    shape = metadata.shape_of(predicted.model_id)
    weights = fit_weights(silhouette, motion)
    tried = [(fit_model(camera, weights, roi, shape, begin_at(start, predicted, stopped_came_from),
                        params, fit_heading=motion is None), start)
             for start in starts]  # a stopped vehicle faces the way it came: only that is fitted
    if motion is None and pipeline.keep_start_after_shadow:
        refits = [(refit_with_restarts(camera, silhouette, roi, shape, fit, params), start) for fit, start in tried]
        (first, weights), start = max(refits, key=lambda pair: pair[0][0].iou)
    else:
        first, start = max(tried, key=lambda pair: pair[0].iou)
        if motion is None:  # a moving vehicle's heading is its path's, and its records many: no shadow refit
            first, weights = refit_with_restarts(camera, silhouette, roi, shape, first, params)
    fits = [first] + [  # the other models start facing the way the predicted one was fitted: front and rear are settled
        fit_model(camera, weights, roi, metadata.shape_of(spec.model_id), begin_at(start, spec, first.box.heading_deg),
                  replace(settings.fit, try_reversed=False), fit_heading=motion is None)
        for spec in (metadata.classes[index] for index in candidates[1:])]
    box = facing(first.box, came_deg) if came_deg is not None else first.box
    dimensions = fitted_spread([f.box for f in fits], probabilities[candidates]) if len(fits) > 1 else (0.0, 0.0)
    if motion is None:
        uncertainty = Uncertainty.combined(dimensions, calibration_part_of(points.calibration, box, box.length_mm / 2))
    else:  # the heading is the path's: the calibration turns it over the path's extent, not over the car
        uncertainty = Uncertainty.combined(dimensions, calibration_part_of(points.calibration, box, motion.extent_mm),
                                           (0.0, motion.sigma_deg))
    return Estimate("fit", box, None, uncertainty, first.iou, start_kind)


def fit_weights(silhouette: Silhouette, motion: PathHeading | None) -> np.ndarray:
    """What the model fit matches: the silhouette's weights, with the outline's pixels weighing the share of them the
    vehicle covers for a vehicle without a path heading (measured on still cars; on the real highway clip's moving
    vehicles they moved 13 of 17 fronts further short of the hand-read ones, a median 0.08 m, one beyond 1.5 m)."""
    return silhouette.weights_at_edges() if motion is None else silhouette.weights


def joined(*reasons: str) -> str:
    """The non-empty reasons of a record, in one line."""
    return "; ".join(filter(None, reasons))


def not_localized(track: VehicleTrack, frame_index: int, why: NotPlaced) -> VehicleRecord:
    """The record of a vehicle that is not localized before it is classified."""
    return VehicleRecord(track.track_id, frame_index, track.box, Status.NOT_LOCALIZED, why.code, why.message)


def poor_fit(fit: Estimate) -> str:
    """Why a model fit is not reported: its silhouette barely overlaps the vehicle's (the blob is not one
    vehicle, or not the vehicle at all)."""
    return f"the model fit does not explain the silhouette (overlap {fit.iou:.2f} < pipeline.min_fit_iou)"


def localize_frames(localizer: Localizer, frames: Iterable[np.ndarray]) -> Iterator[VehicleRecord]:
    """Run the localizer over frames, yielding the records as they come."""
    for frame_index, frame in enumerate(frames):
        yield from localizer.process(frame_index, frame)
