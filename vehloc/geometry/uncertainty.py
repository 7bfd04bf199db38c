"""1-sigma uncertainty of a localization, from the sources the system knows of: the classifier's doubt about
the model (the spread of the top-k models' dimensions, or of the poses fitted with their shapes), the
calibration (its reprojection error, turned into millimetres on the road where the vehicle stands) and, for a
heading taken from a moving vehicle's path, that path's (`vehloc.geometry.motion`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.data.dimension_error import top_k_classes
from vehloc.geometry.placement import VehicleBox, axis_difference_deg
from vehloc.geometry.projective import ProjectiveTransform


@dataclass(frozen=True)
class Uncertainty:
    """1-sigma of the centre (mm, radial) and the heading (deg), and the parts they combine."""

    position_mm: float
    heading_deg: float
    dimensions: tuple[float, float]
    calibration: tuple[float, float]
    motion: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def combined(cls, dimensions: tuple[float, float], calibration: tuple[float, float],
                 motion: tuple[float, float] = (0.0, 0.0)) -> Uncertainty:
        """The independent parts (position mm, heading deg) added in quadrature; `motion` is the share of a heading
        taken from the vehicle's path."""
        return cls(float(np.hypot.reduce([dimensions[0], calibration[0], motion[0]])),
                   float(np.hypot.reduce([dimensions[1], calibration[1], motion[1]])), dimensions, calibration, motion)


def dimension_spread_mm(probabilities: np.ndarray, class_dims_mm: np.ndarray, top_k: int) -> np.ndarray:
    """(3,) probability-weighted standard deviation of length, width and height over the top-k classes of one
    probability row (renormalised over those k)."""
    top = top_k_classes(np.asarray(probabilities, dtype=float)[None], min(top_k, len(probabilities)))[0]
    weights = np.asarray(probabilities, dtype=float)[top]
    weights = weights / weights.sum()
    dims = np.asarray(class_dims_mm, dtype=float)[top]
    mean = weights @ dims
    return np.sqrt(weights @ (dims - mean) ** 2)


def road_mm_per_px(road_to_image: ProjectiveTransform, point_mm: np.ndarray) -> float:
    """How many millimetres on the road one pixel spans at a road point, in its worst direction (the largest
    singular value of the image-to-road Jacobian there)."""
    centre_px = road_to_image.map_visible(np.asarray(point_mm, dtype=float).reshape(1, 2), "road point")
    jacobian = road_to_image.inverse.jacobian(centre_px)[0]
    return float(np.linalg.svd(jacobian, compute_uv=False)[0])


def calibration_part(rms_reprojection_px: float, mm_per_px: float, baseline_mm: float,
                     scale_position_mm: float = 0.0) -> tuple[float, float]:
    """The calibration's share: the reprojection error at the vehicle (mm), with the scale's error there
    (`scale_position_mm`: its relative 1-sigma times the distance from the camera's foot) in quadrature, and the turn
    the reprojection error makes over the `baseline_mm` that sets the heading (deg)."""
    position_mm = rms_reprojection_px * mm_per_px
    return float(np.hypot(position_mm, scale_position_mm)), float(np.degrees(np.sqrt(2.0) * position_mm / baseline_mm))


def paper_dimension_part(kind: str, spread_mm: np.ndarray) -> tuple[float, float]:
    """The model doubt's share of the paper's placement: the plate branch puts the centre half a length from
    the end (sigma_L / 2), the wheel branch half a width from the side (sigma_W / 2); the heading comes from
    the footprint lines, not from the dimensions. From one wheel (`wheel`) half a wheelbase along the side too, its
    doubt taken as the length's."""
    if kind == "plate":
        return float(spread_mm[0]) / 2, 0.0
    if kind == "wheel":
        return float(np.hypot(spread_mm[0], spread_mm[1])) / 2, 0.0
    return float(spread_mm[1]) / 2, 0.0


def fitted_spread(boxes: list[VehicleBox], weights: np.ndarray) -> tuple[float, float]:
    """Probability-weighted spread (position mm, heading deg) of the poses fitted with the top-k models'
    shapes around their weighted mean."""
    weights = np.asarray(weights, dtype=float) / np.sum(weights)
    centres = np.array([box.centre_mm for box in boxes])
    mean = weights @ centres
    position = float(np.sqrt(weights @ np.sum((centres - mean) ** 2, axis=1)))
    turns = np.array([axis_difference_deg(box.heading_deg, boxes[0].heading_deg) for box in boxes])
    heading = float(np.sqrt(weights @ (turns - weights @ turns) ** 2))
    return position, heading
