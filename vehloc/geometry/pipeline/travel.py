"""Which way a tracked vehicle travels, by one rule: the principal direction of its box bottom's road path, pointed
the way its constant-speed motion along it goes (`vehloc.geometry.motion.path_heading`), over its whole path (the
way it came, and so the end it shows the camera) and over its recent frames while it moves (where it points now,
with the path's 1-sigma, or why that path cannot tell)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.motion import PathHeading, path_heading, recent_path
from vehloc.geometry.outcome import NotPlaced, ReasonCode
from vehloc.geometry.placement import direction_of
from vehloc.geometry.projective import ProjectiveTransform
from vehloc.geometry.pipeline.settings import PipelineParams
from vehloc.geometry.pipeline.tracker import VehicleTrack


@dataclass(frozen=True)
class Travel:
    """A tracked vehicle's travel at one frame: whether it moves (is not still to the tracker), its whole path's
    heading (the way it came; None when the path spans less than `pipeline.min_travel_mm` or its constant-speed
    motion does not tell which way, within `pipeline.min_speed_sigmas` of standing still), the end it shows the
    camera (`front` when it came towards the camera's foot, `rear` when it went away), and for a moving vehicle its
    recent path's heading or why that path does not give it."""

    moving: bool
    came_heading_deg: float | None
    visible_end: str | None
    recent: PathHeading | None = None
    unclear: NotPlaced | None = None

    @property
    def motion(self) -> PathHeading | None:
        """The heading a moving vehicle points in now, when its recent path tells it."""
        return self.recent if self.moving and self.unclear is None else None


def track_travel(track: VehicleTrack, frame_index: int, moving: bool, params: PipelineParams,
                 road_to_image: ProjectiveTransform, camera_foot_mm: np.ndarray) -> Travel:
    """The travel of `track` at `frame_index`; `moving` as the tracker says (with `pipeline.heading_from_motion`)."""
    points = np.array(track.ground_points_mm, dtype=float).reshape(-1, 2)
    whole = path_heading(points, np.array(track.ground_frames, dtype=float), params.min_travel_mm, road_to_image,
                         params.motion_jitter_px)
    came = visible_end = None
    if whole is not None and whole.speed_sigmas >= params.min_speed_sigmas:
        came = whole.heading_deg
        middle = points[np.all(np.isfinite(points), axis=1)].mean(axis=0)
        towards = float(direction_of(came) @ (np.asarray(camera_foot_mm, dtype=float) - middle)) > 0
        visible_end = "front" if towards else "rear"
    if not moving:
        return Travel(False, came, visible_end)
    points, frames = recent_path(track.ground_points_mm, track.ground_frames, frame_index, params.motion_window_frames,
                                 params.motion_max_gap_frames)
    recent = path_heading(points, frames, params.min_travel_mm, road_to_image, params.motion_jitter_px)
    return Travel(True, came, visible_end, recent, unclear_path(recent, params))


def unclear_path(path: PathHeading | None, params: PipelineParams) -> NotPlaced | None:
    """Why a moving vehicle's recent path cannot give its heading (too short, too irregular, or not telling which
    way it goes); None when it can."""
    if path is None:
        return NotPlaced(ReasonCode.PATH_TOO_SHORT,
                         f"it moves, but its path over the last {params.motion_window_frames} frames spans less than "
                         f"{params.min_travel_mm:.0f} mm (pipeline.min_travel_mm)")
    if path.sigma_deg > params.max_motion_sigma_deg:
        return NotPlaced(ReasonCode.PATH_HEADING_UNCERTAIN,
                         f"it moves, but its path's heading is uncertain (sigma {path.sigma_deg:.1f} deg > "
                         f"pipeline.max_motion_sigma_deg)")
    if path.speed_sigmas < params.min_speed_sigmas:
        return NotPlaced(ReasonCode.PATH_WAY_UNCLEAR,
                         f"it moves, but its path does not tell which way (its speed along it, "
                         f"{path.speed_sigmas:.1f} sigma, is below pipeline.min_speed_sigmas)")
    return None
