"""The paper's Table 2: a localization against the true pose, in millimetres, degrees and per cent.

The true pose comes from the four tyre positions and the vehicle's specifications (the paper marks the tyres
on the road). Errors are estimated minus true; X is given in % of the vehicle's length, Y in % of its width
and the position in % of its footprint diagonal, as the paper does (Middle 0: 118 mm of a 4920 mm car is
2.40 %); the orientation error is that of the length axis. The combined accuracy adds a dimension error
in quadrature: sqrt(2.85^2 + 2.5^2) = 3.79 % in the paper.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.placement import VehicleBox, axis_difference_deg, heading_of, unit

PAPER_POSITION_PCT = 2.85
PAPER_HEADING_DEG = 2.5
PAPER_DIMENSION_PCT = 2.5


def true_box_from_tyres(tyres_mm: np.ndarray, axle_middle_x_mm: float, length_mm: float, width_mm: float) -> VehicleBox:
    """The footprint of a vehicle from its tyre contacts (4, 2): front-left, front-right, rear-left,
    rear-right, and where the middle between its axles lies along it (`axle_middle_x_mm`, from the
    footprint's centre towards the front, from the specifications)."""
    tyres = np.asarray(tyres_mm, dtype=float).reshape(4, 2)
    front, rear = tyres[:2].mean(axis=0), tyres[2:].mean(axis=0)
    forward = unit(front - rear)
    centre = (front + rear) / 2 - forward * axle_middle_x_mm
    return VehicleBox(centre, heading_of(forward), length_mm, width_mm)


@dataclass(frozen=True)
class PoseError:
    """Estimated minus true: centre X, Y and distance (mm), length-axis orientation (deg), and the
    paper's percentages."""

    x_mm: float
    y_mm: float
    position_mm: float
    heading_deg: float
    x_pct: float
    y_pct: float
    position_pct: float

    def within_paper(self) -> bool:
        """Whether the error is within the paper's figures: position <= 2.85 % and heading <= 2.5 deg."""
        return self.position_pct <= PAPER_POSITION_PCT and abs(self.heading_deg) <= PAPER_HEADING_DEG


def pose_error(estimated: VehicleBox, true: VehicleBox) -> PoseError:
    """The errors of an estimate against the true box, relative to the true box's size."""
    dx, dy = np.asarray(estimated.centre_mm, dtype=float) - np.asarray(true.centre_mm, dtype=float)
    position = float(np.hypot(dx, dy))
    diagonal = float(np.hypot(true.length_mm, true.width_mm))
    return PoseError(
        x_mm=float(dx), y_mm=float(dy), position_mm=position,
        heading_deg=axis_difference_deg(estimated.heading_deg, true.heading_deg),
        x_pct=100.0 * abs(dx) / true.length_mm, y_pct=100.0 * abs(dy) / true.width_mm,
        position_pct=100.0 * position / diagonal,
    )


def combined_accuracy_pct(position_pct: float, dimension_pct: float = PAPER_DIMENSION_PCT) -> float:
    """Localization and dimension errors added in quadrature (the paper's final 3.79 %)."""
    return float(np.hypot(position_pct, dimension_pct))
