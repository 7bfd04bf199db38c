"""A vehicle's model checked against its boxes once the video's vehicles are known.

A model named wrong puts the vehicle's roof at the wrong height, and its speed off by the height's error over the
camera's (a roof 0.2 m too high seen from 9 m: 2.5 % slow). The vote's likeliest models each placed by the box's top
predict how tall the vehicle's box should be; the box is taller than a shape of the right model by what lies under
every vehicle of the video alike (its cast shadow, the background model's blur), which the vehicles the vote is sure of
measure (`BoxHeightReference`). Each vehicle then takes the candidate most probable given both its vote and its boxes'
height: the vote's probability times the likelihood of its box height excess (a normal of the sure vehicles' median
and robust spread). Too few sure vehicles: every vote stands.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vehloc.geometry.pipeline.track_speed import ModelCandidate, ModelSource, SpeedParams, VehicleSpeed
from vehloc.geometry.speed import SpeedFit

MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class BoxHeightReference:
    """The box height excess of the video's vehicles of sure models: median, robust 1-sigma, how many vehicles."""

    excess: float
    sigma: float
    vehicles: int


def box_height_reference(vehicles: Sequence[VehicleSpeed], params: SpeedParams) -> BoxHeightReference | None:
    """The reference from the measured vehicles whose vote gives its first model at least
    `reference_min_probability`; None with fewer than `min_reference_vehicles` of them."""
    excesses = np.array([v.candidates[0].box_height_excess for v in vehicles
                         if v.candidates and v.candidates[0].probability >= params.reference_min_probability
                         and isinstance(v.candidates[0].speed, SpeedFit)], dtype=float)
    excesses = excesses[np.isfinite(excesses)]
    if len(excesses) < params.min_reference_vehicles:
        return None
    median = float(np.median(excesses))
    sigma = max(MAD_TO_SIGMA * float(np.median(np.abs(excesses - median))), params.min_excess_sigma)
    return BoxHeightReference(median, sigma, len(excesses))


def candidate_cost(candidate: ModelCandidate, reference: BoxHeightReference) -> float:
    """-log of the candidate's probability given the vote and its boxes' height (up to a constant); inf for a
    candidate without a speed or an excess."""
    if not (isinstance(candidate.speed, SpeedFit) and np.isfinite(candidate.box_height_excess)
            and candidate.probability > 0.0):
        return float("inf")
    return float(-np.log(candidate.probability)
                 + 0.5 * ((candidate.box_height_excess - reference.excess) / reference.sigma) ** 2)


def choose_models(vehicles: Sequence[VehicleSpeed], params: SpeedParams) -> list[VehicleSpeed]:
    """Each vehicle as its likeliest candidate given its vote and its boxes' height (`ModelSource.BOX_HEIGHT` where
    that is not the vote's first); the vehicles as they are without a reference."""
    reference = box_height_reference(vehicles, params)
    if reference is None:
        return list(vehicles)
    chosen = []
    for vehicle in vehicles:
        costs = [candidate_cost(c, reference) for c in vehicle.candidates]
        best = int(np.argmin(costs)) if costs and np.isfinite(min(costs)) else 0
        chosen.append(vehicle.with_candidate(vehicle.candidates[best], ModelSource.BOX_HEIGHT) if best else vehicle)
    return chosen
