"""Moving vehicles of a rendered scene against its ground truth (`ground_truth.json`: every car's pose and box in every
frame it is in): each localized record matched to the car whose true box overlaps its box most (at least `min_iou`),
and its model fit's errors: the centre's, the near end's (the middle of the footprint's end nearest the camera's foot,
as the highway clip's hand truth reads a front; signed along the car's heading, + away from the camera) and the
heading's, as Table 2 defines it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vehloc.benchmark.spot_truth import front_mm
from vehloc.data.boxes import Box
from vehloc.data.text import read_json
from vehloc.geometry.pipeline.localize import Status, VehicleRecord
from vehloc.geometry.pipeline.table2 import pose_error
from vehloc.geometry.placement import VehicleBox


@dataclass(frozen=True)
class TruthCar:
    """One car of a scene's ground truth: its model and, from frame `first_frame` on, its footprint and its image box
    in each frame (None where it has none)."""

    index: int
    model_id: int
    footprints: tuple[VehicleBox | None, ...]
    boxes_px: tuple[Box | None, ...]
    first_frame: int

    def at(self, frame: int) -> tuple[VehicleBox, Box] | None:
        """The car's footprint and image box at `frame`; None where it has no box then."""
        k = frame - self.first_frame
        if not 0 <= k < len(self.boxes_px) or self.boxes_px[k] is None or self.footprints[k] is None:
            return None
        return self.footprints[k], self.boxes_px[k]


def read_truth_cars(path: str | Path) -> list[TruthCar]:
    """The cars of a scene's `ground_truth.json` (`vehloc.synth.scene.ground_truth`)."""
    cars = []
    for index, car in enumerate(read_json(Path(path))["cars"]):
        footprints = tuple(None if pose is None else VehicleBox(np.array([pose["x_mm"], pose["y_mm"]]),
                                                                 pose["heading_deg"], car["length_mm"], car["width_mm"])
                           for pose in car["poses"])
        boxes = tuple(None if box is None else Box.from_inclusive(*box) for box in car["boxes_xyxy_px"])
        cars.append(TruthCar(index, int(car["model_id"]), footprints, boxes, int(car["per_frame_from"])))
    return cars


@dataclass(frozen=True)
class MovingError:
    """One localized record's model fit against its car at that frame (mm, deg): the distance from the camera's foot
    to the car's centre, the centre's and the near end's errors, the near end's along the car's heading (+ away from
    the camera) and the heading's, signed (the length axes' difference, in [-90, 90))."""

    frame: int
    track_id: int
    car_index: int
    model_named: bool
    distance_mm: float
    centre_error_mm: float
    near_end_error_mm: float
    near_end_along_mm: float
    heading_error_deg: float


def matched_car(box_px: Box, cars: list[TruthCar], frame: int, min_iou: float) -> tuple[TruthCar, VehicleBox] | None:
    """The car whose true box at `frame` overlaps `box_px` most, with its footprint; None below `min_iou`."""
    best, best_iou = None, min_iou
    for car in cars:
        truth = car.at(frame)
        if truth is None:
            continue
        iou = box_px.iou(truth[1])
        if iou >= best_iou:
            best, best_iou = (car, truth[0]), iou
    return best


def moving_error(record: VehicleRecord, cars: list[TruthCar], camera_foot_mm: np.ndarray,
                 min_iou: float) -> MovingError | None:
    """The errors of a localized record's model fit against the car it is matched to; None for a record not localized,
    without a fit, or matched to no car."""
    fit = record.estimate("fit") if record.status == Status.LOCALIZED else None
    matched = matched_car(record.box_px, cars, record.frame, min_iou) if fit is not None else None
    if matched is None:
        return None
    car, truth = matched
    foot = np.asarray(camera_foot_mm, dtype=float)[:2]
    end_error = front_mm(fit.box.corners_mm(), foot) - front_mm(truth.corners_mm(), foot)
    away = truth.forward if truth.forward @ (truth.centre_mm - foot) > 0 else -truth.forward
    error = pose_error(fit.box, truth)
    return MovingError(record.frame, record.track_id, car.index, record.model_id == car.model_id,
                       float(np.linalg.norm(truth.centre_mm - foot)), error.position_mm,
                       float(np.linalg.norm(end_error)), float(end_error @ away), error.heading_deg)
