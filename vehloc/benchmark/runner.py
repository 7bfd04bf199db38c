"""One benchmark case end to end: its scene rendered into a video as `vehloc-scene` writes one (a temporary file)
and read frame by frame into the localization pipeline (the camera's exact calibration, the settings of
`conf/localize/`), the stopped car's record matched as Table 2 matches it, and one row of results: what was visible, localized or not and why, the key point, and both
methods' errors as Table 2 defines them."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from itertools import islice
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from vehloc.benchmark.cases import BenchmarkCase, DrawParams
from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.benchmark.visibility import TYRE_NAMES, Visibility, VisibilityParams, visibility
from vehloc.data.boxes import Box
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.pipeline.drawing import METHOD_COLOURS_BGR, draw_cuboid
from vehloc.geometry.pipeline.evaluation import NOT_TRACKED_TO_STOP, at_stop, is_stop_record
from vehloc.geometry.pipeline.localize import Localizer, RecordInputs, Status, VehicleRecord
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.pipeline.table2 import pose_error, true_box_from_tyres
from vehloc.geometry.uncertainty import road_mm_per_px
from vehloc.geometry.pipeline.video import iter_frames
from vehloc.infer.classifier import VehicleClassifier
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import tyre_contacts_car_mm
from vehloc.synth.scene import CameraSpec, SceneSpec, car_pose_at, write_video

FIT_POSITION_PCT, FIT_HEADING_DEG = 1.0, 1.0
"""The model fit's bar: within 1 % of the diagonal and 1 deg."""
EXACT_CALIBRATION_RMS_PX = 0.5
"""The reprojection error the exact calibration is given, for the estimates' uncertainty."""
PICTURE_MARGIN = 0.6
STOP_LOOKAHEAD_FRAMES = 10
"""A case's video is first written this many frames past its stop: in every held-out case with a stop record
(seeds 100000-100199) it came at most 8 frames past the stop, and the frames after it need no rendering, noise or
encoding. Where it has not come, the whole scene is written again, not its rest alone: a video begun mid-scene
encodes its first two frames otherwise (MJPEG at the encoder's own quality)."""


@dataclass(frozen=True)
class CaseOutcome:
    """A case's row of results, where it falls short of a bar a picture of its car with the estimates, and where
    asked what its stop record was made from after the classification (`RecordInputs`)."""

    row: dict[str, object]
    picture_bgr: np.ndarray | None
    inputs: RecordInputs | None = None


def true_box(case: BenchmarkCase) -> VehicleBox:
    """The car's footprint at its stop, from its tyres and specifications (as Table 2 takes it)."""
    model = model_by_id(case.model_id)
    tyres_mm = case.pose.car_to_world(tyre_contacts_car_mm(model))[:, :2]
    return true_box_from_tyres(tyres_mm, (model.front_axle_x_mm + model.rear_axle_x_mm) / 2, model.length_mm,
                               model.width_mm)


def exact_calibration(camera: CameraSpec) -> CameraCalibration:
    pinhole = camera.camera()
    return CameraCalibration(pinhole.road_to_image(), (camera.width_px, camera.height_px), pinhole,
                             EXACT_CALIBRATION_RMS_PX, "the benchmark camera's exact calibration")


@dataclass(frozen=True)
class StoppedCarRun:
    """The stopped car's record (None when there is none), the frame it was made at (else the scene's last)
    with the car's true box there, and how many frames were run."""

    record: VehicleRecord | None
    frame_bgr: np.ndarray
    truth_box_px: Box | None
    frames: int


def localize_stopped_car(spec: SceneSpec, localizer: Localizer, folder: Path) -> StoppedCarRun:
    """Render `spec` into a video in `folder` (its codec, as `vehloc-scene` writes it) and feed its frames to
    `localizer` until the record of its stopped car: the first that `is_stop_record` (Table 2's rule). The video is
    first written up to `STOP_LOOKAHEAD_FRAMES` past the stop; where the record has not come by then, the whole
    scene is written and read on from there (a video's first frames are the same either way)."""
    car = spec.cars[0]
    stop_frame = spec.stop_frame(car)
    model = model_by_id(car.model_id)
    diagonal_mm = float(np.hypot(model.length_mm, model.width_mm))
    first_part = spec.frame_count if stop_frame is None else min(spec.frame_count, stop_frame + STOP_LOOKAHEAD_FRAMES)
    frame_index, frame_bgr, boxes, read = -1, None, [], 0
    for frame_count in dict.fromkeys((first_part, spec.frame_count)):
        video = folder / f"{spec.name}_{frame_count}.avi"
        boxes = write_video(spec, video, frame_count)
        for frame_index, frame_bgr in islice(enumerate(iter_frames(video)), read, None):
            truth_box = boxes[frame_index][0]
            pose = car_pose_at(spec, car, frame_index)
            standing = at_stop(frame_index, stop_frame, None if pose is None else (pose.x_mm, pose.y_mm),
                               (car.target_x_mm, car.target_y_mm), diagonal_mm)
            for record in localizer.process(frame_index, frame_bgr):
                if is_stop_record(record, standing, truth_box):
                    return StoppedCarRun(record, frame_bgr, truth_box, frame_index + 1)
        read = frame_index + 1
    return StoppedCarRun(None, frame_bgr, boxes[frame_index][0], frame_index + 1)


def errors(prefix: str, estimated: VehicleBox, truth: VehicleBox) -> dict[str, object]:
    """A method's errors as Table 2 defines them, and whether they are within its bar (the paper's figures for
    the paper's method, 1 % and 1 deg for the fit)."""
    error = pose_error(estimated, truth)
    within = (error.within_paper() if prefix == "paper" else
              error.position_pct <= FIT_POSITION_PCT and abs(error.heading_deg) <= FIT_HEADING_DEG)
    return {f"{prefix}_position_pct": error.position_pct, f"{prefix}_heading_deg": abs(error.heading_deg),
            f"{prefix}_position_mm": error.position_mm, f"{prefix}_within": bool(within)}


def case_row(case: BenchmarkCase, split: str, seen: Visibility, record: VehicleRecord | None) -> dict[str, object]:
    """The case's row: what it is, what was visible, what the pipeline said and both methods' errors."""
    model = model_by_id(case.model_id)
    row: dict[str, object] = {"split": split, **asdict(case), "model": model.name,
                              "plate_visible": seen.plate, "plate_end": seen.plate_end or "",
                              **{f"tyre_{name}": flag for name, flag in zip(TYRE_NAMES, seen.tyres)},
                              "two_tyres_visible": seen.two_tyres, "key_points_visible": seen.key_points}
    if record is None:
        return row | {"status": Status.NOT_LOCALIZED, "reason_code": NOT_TRACKED_TO_STOP.code,
                      "reason": NOT_TRACKED_TO_STOP.message, "localized": False, "key_point": "", "correct": False}
    return row | record_columns(case, record)


def record_columns(case: BenchmarkCase, record: VehicleRecord) -> dict[str, object]:
    """The row's columns that the stop record makes: its status and reason, the predicted model and both methods'
    errors against the truth."""
    row: dict[str, object] = {
        "status": record.status, "reason_code": record.reason_code or "", "reason": record.reason,
        "notes": record.notes, "localized": record.status == Status.LOCALIZED, "frame": record.frame,
        "predicted_model": f"{record.make} {record.model}".strip(), "correct": record.model_id == case.model_id}
    truth = true_box(case)
    paper, fit = record.estimate("paper"), record.estimate("fit")
    row["key_point"] = paper.key_point if paper is not None else ""
    if paper is not None:
        row |= errors("paper", paper.box, truth)
    if fit is not None:
        row |= errors("fit", fit.box, truth) | {"fit_iou": fit.iou, "fit_start": fit.start,
                                                "fit_sigma_position_mm": fit.uncertainty.position_mm,
                                                "fit_sigma_heading_deg": fit.uncertainty.heading_deg}
    return row


def falls_short(row: dict[str, object]) -> bool:
    """Whether a case misses a bar: not localized, the fit beyond 1 % or 1 deg, or visible key points not
    found or placed beyond the paper's figures."""
    if not row["localized"] or not row.get("fit_within", False):
        return True
    return bool(row["key_points_visible"]) and not row.get("paper_within", False)


def picture(frame_bgr: np.ndarray, case: BenchmarkCase, camera: PinholeCamera, record: VehicleRecord | None,
            truth_px: Box | None) -> np.ndarray:
    """The car's part of the frame with the true box (red) and the estimates (the methods' colours) drawn."""
    image = frame_bgr.copy()
    height_mm = model_by_id(case.model_id).height_mm
    draw_cuboid(image, camera, true_box(case), height_mm, METHOD_COLOURS_BGR["truth"], 1)
    for estimate in record.estimates if record is not None else ():
        draw_cuboid(image, camera, estimate.box, height_mm, METHOD_COLOURS_BGR[estimate.method], 1)
    around = truth_px or Box(0, 0, camera.width_px, camera.height_px)
    return around.enlarged(PICTURE_MARGIN, camera.width_px, camera.height_px).crop(image).copy()


def run_case(case: BenchmarkCase, split: str, site: Mapping[str, Any], camera: CameraSpec, draw: DrawParams,
             seen_params: VisibilityParams, settings: LocalizeSettings | None = None,
             classifier: VehicleClassifier | None = None, capture: bool = False) -> CaseOutcome:
    """Render, localize and score one case with the localization's `settings` (None: the defaults); `classifier` None
    gives the car's true model (the geometry alone); with `capture`, the outcome holds what the stop record was
    made from after the classification (`vehloc.benchmark.replay`)."""
    start = time.perf_counter()
    spec = case.scene_spec(site, camera, draw)
    calibration = exact_calibration(camera)
    seen = visibility(model_by_id(case.model_id), case.pose, calibration.camera, case.plates, seen_params)
    latest: dict[int, RecordInputs] = {}  # each track's last record's inputs

    def keep(inputs: RecordInputs) -> None:
        latest[inputs.classified.track_id] = inputs

    localizer = Localizer(classifier or TrueModelClassifier(case.model_id), calibration, settings,
                          observe_inputs=keep if capture else None)
    with tempfile.TemporaryDirectory(prefix="vehloc-benchmark-") as folder:
        run = localize_stopped_car(spec, localizer, Path(folder))
    record = run.record
    inputs = latest.get(record.track_id) if record is not None else None
    stop_inputs = inputs if inputs is not None and inputs.classified.frame == record.frame else None
    mm_per_px = road_mm_per_px(calibration.road_to_image, true_box(case).centre_mm)
    row = case_row(case, split, seen, run.record) | {
        "camera_x_mm": camera.position_mm[0], "camera_y_mm": camera.position_mm[1], "road_mm_per_px": mm_per_px,
        "frames": run.frames, "seconds": time.perf_counter() - start}
    if not falls_short(row):
        return CaseOutcome(row, None, stop_inputs)
    return CaseOutcome(row, picture(run.frame_bgr, case, calibration.camera, run.record, run.truth_box_px), stop_inputs)


def thumbnail(image_bgr: np.ndarray, size_px: tuple[int, int], caption: str) -> np.ndarray:
    """`image_bgr` letterboxed into `size_px` (width, height) with a caption line under it."""
    width, height = size_px
    cell = np.full((height, width, 3), 245, np.uint8)
    area = height - 16
    scale = min(width / image_bgr.shape[1], area / image_bgr.shape[0])
    resized = cv2.resize(image_bgr, (max(1, int(image_bgr.shape[1] * scale)), max(1, int(image_bgr.shape[0] * scale))),
                         interpolation=cv2.INTER_AREA)
    x0, y0 = (width - resized.shape[1]) // 2, (area - resized.shape[0]) // 2
    cell[y0:y0 + resized.shape[0], x0:x0 + resized.shape[1]] = resized
    cv2.putText(cell, caption[:60], (2, height - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.33, (20, 20, 20), 1, cv2.LINE_AA)
    return cell
