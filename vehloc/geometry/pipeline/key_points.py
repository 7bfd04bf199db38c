"""The key-point stage of one record: what the paper's placement of a tracked vehicle is made from
(`KeyPointInputs`), and the paper's box made from it (`paper_estimate`), the same function the pipeline calls and a replay
calls again on a record's captured inputs (`RecordInputs` of `vehloc.geometry.pipeline.localize`,
`vehloc.benchmark.replay`) with other detector settings, without rendering, tracking or fitting anything."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vehloc.data.boxes import Box
from vehloc.data.shapes import VehicleShape
from vehloc.data.specs import VehicleSpec
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.keypoints import DetectorParams, Placement, paper_placement
from vehloc.geometry.motion import PathHeading
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.placement import axis_difference_deg, between_axles, facing
from vehloc.geometry.roi import Silhouette


@dataclass(frozen=True, eq=False)
class KeyPointInputs:
    """One record's key-point stage: its track and frame, the ROI (its crop, frame px), the vehicle's silhouette in it,
    the calibration, the predicted model (`spec`, `shape`), the end known to face the camera (`front`, `rear` or None),
    the heading the vehicle came from when its travel tells (deg) and its path's heading while it moves."""

    track_id: int
    frame_index: int
    roi_bgr: np.ndarray
    silhouette: Silhouette
    roi: Box
    calibration: CameraCalibration
    spec: VehicleSpec
    shape: VehicleShape
    visible_end: str | None
    came_deg: float | None
    motion: PathHeading | None


def paper_estimate(inputs: KeyPointInputs, detectors: DetectorParams, wheels_at_axles: bool,
                   max_path_gap_deg: float) -> Placement | NotPlaced:
    """The paper's placement from `inputs` (`paper_placement`), its box turned to face the way the vehicle came and,
    from wheels, moved to put the model's axles' middle on Q (`wheels_at_axles`); a moving vehicle's placement lying
    across its own path (`along_path`) is not taken."""
    placement = paper_placement(inputs.roi_bgr, inputs.silhouette, inputs.roi, inputs.calibration, inputs.spec,
                                inputs.shape, detectors, inputs.visible_end)
    if not isinstance(placement, NotPlaced) and inputs.motion is not None:
        placement = along_path(placement, inputs.motion, max_path_gap_deg)
    if isinstance(placement, NotPlaced) or inputs.came_deg is None:
        return placement
    box = facing(placement.box, inputs.came_deg)
    if placement.kind in ("wheels", "wheel") and wheels_at_axles:
        box = between_axles(box, inputs.shape.axle_middle_x_mm)
    return replace(placement, box=box)


def along_path(placement: Placement, motion: PathHeading, max_gap_deg: float) -> Placement | NotPlaced:
    """The paper's placement of a moving vehicle, or why it is not taken: its length axis more than `max_gap_deg`
    off the track's own path (its key points were not the vehicle's)."""
    gap_deg = abs(axis_difference_deg(placement.box.heading_deg, motion.heading_deg))
    if gap_deg <= max_gap_deg:
        return placement
    return NotPlaced(ReasonCode.KEY_POINTS_OFF_PATH,
                     f"the {placement.kind} branch's box lies {gap_deg:.0f} deg off the track's path")
