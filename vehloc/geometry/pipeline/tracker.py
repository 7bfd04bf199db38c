"""One track per vehicle, with a lifecycle (as ByteTrack's): a greedy IoU tracker that follows the background
model's boxes frame to frame, says when a vehicle has stopped, and removes a track once it has been lost for
`max_lost_frames` frames, with everything it held (its boxes, road path and crops for the vote)."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from vehloc.config import check_range, params_from_config
from vehloc.data.boxes import Box
from vehloc.geometry.pipeline.votes import TrackVotes


class TrackState(Enum):
    """Where a track is in its life: seen in its first frame, followed, missed for a few frames, or removed."""

    NEW = "new"
    TRACKED = "tracked"
    LOST = "lost"
    REMOVED = "removed"


@dataclass
class VehicleTrack:
    """One vehicle followed across frames: its boxes, the road points under their bottoms (frames where the
    frame's edge does not cut it), its crops for the classifier's vote, and its state."""

    track_id: int
    votes: TrackVotes
    boxes: list[Box] = field(default_factory=list)
    frames: list[int] = field(default_factory=list)
    ground_points_mm: list[np.ndarray] = field(default_factory=list)
    ground_frames: list[int] = field(default_factory=list)
    stopped_at_frame: int | None = None
    state: TrackState = TrackState.NEW

    @property
    def box(self) -> Box:
        """The box of the last frame the vehicle was seen in."""
        return self.boxes[-1]

    @property
    def last_frame(self) -> int:
        return self.frames[-1]

    def observe(self, box: Box, frame_index: int) -> None:
        """The vehicle's box at this frame."""
        self.boxes.append(box)
        self.frames.append(frame_index)

    def add_ground_point(self, point_mm: np.ndarray, frame_index: int) -> None:
        """The road point under the box's bottom at this frame."""
        self.ground_points_mm.append(point_mm)
        self.ground_frames.append(frame_index)


@dataclass(frozen=True)
class TrackerParams:
    """Association, stop detection and the lifecycle (`conf/localize/tracker/default.yaml`)."""

    min_iou: float
    stop_frames: int
    stop_tolerance_fraction: float
    max_lost_frames: int

    def __post_init__(self) -> None:
        check_range("min_iou", self.min_iou, 0.0, 1.0)
        check_range("stop_frames", self.stop_frames, 2)
        check_range("stop_tolerance_fraction", self.stop_tolerance_fraction, 0.0)
        check_range("max_lost_frames", self.max_lost_frames, 1)

    @classmethod
    def from_config(cls, **overrides: object) -> TrackerParams:
        """The settings of `conf/localize/tracker/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/tracker/default.yaml", overrides)


@dataclass(frozen=True)
class TrackerUpdate:
    """What one frame did to the tracks: those seen at it, those that stopped at it, those removed after it."""

    seen: list[VehicleTrack]
    stopped: list[VehicleTrack]
    removed: list[VehicleTrack]


class StoppedVehicleTracker:
    """Greedy IoU tracker; a track is stopped once its box centre stays, for N frames, within a fraction of the
    box diagonal (blob edges flicker by a few pixels even when the car stands). A track missed in
    `max_lost_frames` frames in a row is removed; each new track keeps up to `vote_frames` crops for its vote, chosen
    by `vote_policy` (`TrackVotes`)."""

    def __init__(self, vote_frames: int, params: TrackerParams | None = None, vote_policy: str = "spread") -> None:
        self.params = params or TrackerParams.from_config()
        self.vote_frames = vote_frames
        self.vote_policy = vote_policy
        self.tracks: list[VehicleTrack] = []
        self._next_id = 1

    @property
    def started(self) -> int:
        """How many tracks were started so far (removed ones included)."""
        return self._next_id - 1

    def update(self, boxes: list[Box], frame_index: int) -> TrackerUpdate:
        """Associate this frame's boxes with the tracks, start a track for each box left over, and remove the
        tracks missed in the last `max_lost_frames` frames."""
        unmatched = list(boxes)
        for track in sorted(self.tracks, key=lambda t: -t.box.area_px):
            if not unmatched:
                break
            overlaps = [track.box.iou(b) for b in unmatched]
            best = int(np.argmax(overlaps))
            if overlaps[best] >= self.params.min_iou:
                track.observe(unmatched.pop(best), frame_index)
        for box in unmatched:
            track = VehicleTrack(self._next_id, TrackVotes(self.vote_frames, self.vote_policy))
            track.observe(box, frame_index)
            self.tracks.append(track)
            self._next_id += 1
        seen, stopped, removed, kept = [], [], [], []
        for track in self.tracks:
            if track.last_frame == frame_index:
                track.state = TrackState.NEW if len(track.frames) == 1 else TrackState.TRACKED
                seen.append(track)
                if track.stopped_at_frame is None and self.is_still(track):
                    track.stopped_at_frame = frame_index
                    stopped.append(track)
            elif frame_index - track.last_frame >= self.params.max_lost_frames:
                track.state = TrackState.REMOVED
                removed.append(track)
                continue
            else:
                track.state = TrackState.LOST
            kept.append(track)
        self.tracks = kept
        return TrackerUpdate(seen, stopped, removed)

    def is_still(self, track: VehicleTrack) -> bool:
        """Whether the track's box centre stayed put over its last `stop_frames` frames, seen one after another."""
        n = self.params.stop_frames
        if len(track.boxes) < n or track.frames[-1] - track.frames[-n] != n - 1:
            return False
        centres = np.array([b.centre_px for b in track.boxes[-n:]])
        tolerance_px = self.params.stop_tolerance_fraction * np.hypot(track.box.width_px, track.box.height_px)
        return float(np.max(np.linalg.norm(centres - centres[-1], axis=1))) <= tolerance_px
