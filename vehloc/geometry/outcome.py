"""Failures as values: a stage that cannot do its job returns a `NotPlaced` saying why, a machine-readable code
and a sentence (as scikit-image's `FailedEstimation`), never an exception that ends the video; an estimate of the
scene (a vanishing point, a camera) that the evidence cannot give is a `FailedEstimate` with its sentence.
Exceptions stay for bad input and bugs."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class ReasonCode(StrEnum):
    """Why a vehicle is not localized: the codes of the records, for tables and tests to count."""

    TOUCHES_EDGE = "touches_edge"
    TOO_SMALL_TO_CLASSIFY = "too_small_to_classify"
    NO_FOOTPRINT_LINES = "no_footprint_lines"
    NO_KEY_POINTS = "no_key_points"
    PLATE_PARALLEL_TO_FRONT = "plate_parallel_to_front"
    KEY_POINTS_OFF_PATH = "key_points_off_path"
    ON_HORIZON = "on_horizon"
    PATH_TOO_SHORT = "path_too_short"
    PATH_HEADING_UNCERTAIN = "path_heading_uncertain"
    PATH_WAY_UNCLEAR = "path_way_unclear"
    POOR_FIT = "poor_fit"
    NOT_TRACKED_TO_STOP = "not_tracked_to_stop"
    BOX_NOT_MODEL_SIZE = "box_not_model_size"
    PATH_ACROSS_TRAFFIC = "path_across_traffic"


@dataclass(frozen=True)
class NotPlaced:
    """A stage's failure to place a vehicle: its code and a sentence saying why. False in a condition, so that
    `if not result:` reads as "if it failed"."""

    code: ReasonCode
    message: str

    def __bool__(self) -> bool:
        return False

    def __str__(self) -> str:
        return self.message


@dataclass(frozen=True)
class FailedEstimate:
    """Why the evidence gives no estimate (a vanishing point, a camera): a sentence. False in a condition."""

    message: str

    def __bool__(self) -> bool:
        return False

    def __str__(self) -> str:
        return self.message
