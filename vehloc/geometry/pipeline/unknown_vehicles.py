"""Vehicles of no likely model's size, measured by their box's bottom (`TrackSpeeds.unknown`), told apart from
boxes that held two vehicles and from fragments: a box that held another measured vehicle (where that one's steady
motion puts it, in the image) in more than a fraction of its frames was their merged blob, not a truck, and its box's
bottom the nearer one's; a speed whose 1-sigma is a large fraction of it was a fragment's, seen a few metres. Neither
is measured."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.pipeline.track_speed import ModelSource, SpeedParams, VehicleSpeed
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.speed import SpeedFit


def held_fraction(vehicle: VehicleSpeed, others: Sequence[VehicleSpeed], road_to_image: ProjectiveTransform,
                  within_mm: float) -> float:
    """The fraction of `vehicle`'s used frames whose box holds the pixel of some other vehicle's steady motion at that
    frame (within that vehicle's own first and last frame: not where one vehicle's two tracks follow each other) where
    that point is within `within_mm` of the vehicle's own on the road (beside it or just behind: not the far road a
    tall box covers in the image)."""
    used = vehicle.used
    frames, boxes, points = vehicle.path.frames[used], vehicle.path.boxes_px[used], vehicle.path.points_mm[used]
    held = np.zeros(len(frames), bool)
    for other in others:
        during = (frames >= other.first_frame) & (frames <= other.last_frame)
        if not during.any():
            continue
        positions = other.speed.positions_mm(frames[during] / other.fps)
        pixels = road_to_image(positions)
        inside = ((pixels[:, 0] >= boxes[during, 0]) & (pixels[:, 0] < boxes[during, 2])
                  & (pixels[:, 1] >= boxes[during, 1]) & (pixels[:, 1] < boxes[during, 3])
                  & (np.linalg.norm(positions - points[during], axis=1) <= within_mm))
        held[np.flatnonzero(during)[inside]] = True
    return float(held.mean()) if len(held) else 0.0


def refusal(vehicle: VehicleSpeed, known: Sequence[VehicleSpeed], params: SpeedParams,
            road_to_image: ProjectiveTransform) -> NotPlaced | None:
    """Why a vehicle measured by its box's bottom is not measured after all (None where it is): its speed's 1-sigma
    more than `unknown_max_sigma_fraction` of it (a fragment), or its boxes holding one of the `known` vehicles in more
    than `unknown_max_held_fraction` of its frames (that vehicle within `unknown_held_within_mm` of its own point)."""
    sigma_fraction = vehicle.speed.sigma_kmh / vehicle.speed.speed_kmh
    if sigma_fraction > params.unknown_max_sigma_fraction:
        return NotPlaced(ReasonCode.BOX_NOT_MODEL_SIZE, (
            f"its speed, measured by the bottom of boxes of no likely model's size, is {sigma_fraction:.0%} "
            f"uncertain, more than {params.unknown_max_sigma_fraction:.0%} (speed.unknown_max_sigma_fraction): "
            "a fragment"))
    fraction = held_fraction(vehicle, [v for v in known if v.track_id != vehicle.track_id], road_to_image,
                             params.unknown_held_within_mm)
    if fraction > params.unknown_max_held_fraction:
        return NotPlaced(ReasonCode.BOX_NOT_MODEL_SIZE, (
            f"its boxes, of no likely model's size, held another measured vehicle in {fraction:.0%} of its frames, "
            f"more than {params.unknown_max_held_fraction:.0%} (speed.unknown_max_held_fraction): their merged blob"))
    return None


def apart_from_known(vehicles: Sequence[VehicleSpeed], params: SpeedParams,
                     road_to_image: ProjectiveTransform) -> list[VehicleSpeed]:
    """The vehicles, each measured one of no likely model's size not measured where it has a `refusal`."""
    known = [v for v in vehicles if isinstance(v.speed, SpeedFit) and v.model_source != ModelSource.UNKNOWN]
    result = []
    for vehicle in vehicles:
        if vehicle.model_source == ModelSource.UNKNOWN and isinstance(vehicle.speed, SpeedFit):
            failure = refusal(vehicle, known, params, road_to_image)
            vehicle = vehicle if failure is None else replace(vehicle, speed=failure)
        result.append(vehicle)
    return result
