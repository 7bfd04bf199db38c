"""One track per vehicle, with a lifecycle (as ByteTrack's): a greedy IoU tracker that follows the background
model's boxes frame to frame (each track's box looked for where its motion takes it, `motion_frames`), says when a
vehicle has stopped, and removes a track once it has been lost for `max_lost_frames` frames, with everything it held
(its boxes, road path and crops for the vote).

Two vehicles whose blobs merge (one overtaking the other, seen side by side) make one box for a while. The larger
track takes it; the other, missed where that box covers where it should be, is hidden in it (`max_hidden_frames`):
kept, its hidden frames and their boxes recorded (its steady motion on the road is reported through them), and
found again where its motion takes it when the blob parts. Where `max_shared_frames` is on, the two share the box
instead: neither takes it as its own (it is neither vehicle's box), both stay alive while the blob lasts, and when it
parts each takes the part nearest where it should be."""

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
    shared_box: Box | None = None
    """The box it shares with other tracks in the last frame (their blobs merged), None when it has its own."""
    shared_frames: int = 0
    hidden_frames: list[int] = field(default_factory=list)
    """The frames it was missed in where a box another track took covered where it should be: hidden in that
    vehicle's blob (side by side, one passing in front of the other), not gone."""
    hidden_boxes: list[Box] = field(default_factory=list)
    """The box it was hidden in, at each of `hidden_frames`."""

    @property
    def last_accounted_frame(self) -> int:
        """The last frame it was seen or hidden in."""
        return max(self.last_frame, self.hidden_frames[-1]) if self.hidden_frames else self.last_frame

    @property
    def box(self) -> Box:
        """The box of the last frame the vehicle was seen in."""
        return self.boxes[-1]

    @property
    def last_frame(self) -> int:
        return self.frames[-1]

    def predicted_box(self, frame_index: int, motion_frames: int) -> Box:
        """Where the box should be at `frame_index`: the last box moved on by its edges' constant-velocity motion
        fitted over the last `motion_frames` frames seen (the last box as it was with fewer than two of them, or
        `motion_frames` under 2), so that a vehicle hidden for a few frames is found again where it drove on to."""
        seen = min(motion_frames, len(self.boxes))
        if seen < 2 or frame_index <= self.last_frame:
            return self.box
        frames = np.array(self.frames[-seen:], dtype=float)
        edges = np.array([[b.x0, b.y0, b.x1, b.y1] for b in self.boxes[-seen:]], dtype=float)
        spread = frames - frames.mean()
        velocity = spread @ (edges - edges.mean(axis=0)) / float(spread @ spread)
        moved = edges[-1] + velocity * (frame_index - self.last_frame)
        x0, y0, x1, y1 = (int(round(v)) for v in moved)
        return Box(x0, y0, max(x1, x0 + 1), max(y1, y0 + 1))

    def unobserve(self) -> Box:
        """Take back the last frame's box (it was shared with another vehicle); returns it."""
        self.frames.pop()
        return self.boxes.pop()

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
    stop_flicker_frames: int
    max_lost_frames: int
    motion_frames: int
    max_shared_frames: int
    shared_min_cover: float
    max_hidden_frames: int
    fragment_min_inside: float
    fragment_min_iou: float

    def __post_init__(self) -> None:
        check_range("fragment_min_inside", self.fragment_min_inside, 0.0, 1.0, low_open=True)
        check_range("fragment_min_iou", self.fragment_min_iou, 0.0, 1.0)
        check_range("motion_frames", self.motion_frames, 0)
        check_range("max_shared_frames", self.max_shared_frames, 0)
        check_range("max_hidden_frames", self.max_hidden_frames, 0)
        check_range("shared_min_cover", self.shared_min_cover, 0.0, 1.0, low_open=True)
        check_range("min_iou", self.min_iou, 0.0, 1.0)
        check_range("stop_frames", self.stop_frames, 2)
        check_range("stop_tolerance_fraction", self.stop_tolerance_fraction, 0.0)
        check_range("stop_flicker_frames", self.stop_flicker_frames, 0, self.stop_frames - 2)
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
    """Greedy IoU tracker; a track is stopped once its box's middle stays for N frames within a fraction of the box
    diagonal, taken at the height of its top or bottom where the other flickers (blob edges flicker by a few pixels
    even when the car stands). A track missed in `max_lost_frames` frames in a row is removed; each new track keeps
    up to `vote_frames` crops for its vote, chosen by `vote_policy` (`TrackVotes`)."""

    def __init__(self, vote_frames: int, params: TrackerParams | None = None, vote_policy: str = "spread",
                 box_step_px: float = 1.0) -> None:
        """`box_step_px`: how finely the boxes' edges are placed, in frame pixels (one pixel of the background
        model's shrunk frames, 1 / `roi.scale`): an edge moving smoothly strays from its smooth motion by up to half
        of it, which is no flicker (see `is_still`)."""
        self.params = params or TrackerParams.from_config()
        self.box_step_px = box_step_px
        self.vote_frames = vote_frames
        self.vote_policy = vote_policy
        self.tracks: list[VehicleTrack] = []
        self._next_id = 1
        self.frame_height_px: int | None = None

    @property
    def started(self) -> int:
        """How many tracks were started so far (removed ones included)."""
        return self._next_id - 1

    def update(self, boxes: list[Box], frame_index: int, frame_height_px: int | None = None) -> TrackerUpdate:
        """Associate this frame's boxes with the tracks (each track's box where its motion takes it), share a box
        among the tracks it covers, start a track for each box left over, and remove the tracks missed in the last
        `max_lost_frames` frames (or shared for more than `max_shared_frames`). With the frame's height, a box's top
        or bottom held at the frame's edge is never taken as the steady one (see `is_still`)."""
        self.frame_height_px = frame_height_px
        expected = {t.track_id: t.predicted_box(frame_index, self.params.motion_frames) for t in self.tracks}
        unmatched, sharing = self.still_shared(list(boxes))
        for track in sorted(self.tracks, key=lambda t: -t.box.area_px):
            if not unmatched:
                break
            if track.track_id in sharing:
                continue
            overlaps = [expected[track.track_id].iou(b) for b in unmatched]
            best = int(np.argmax(overlaps))
            if overlaps[best] >= self.params.min_iou:
                track.observe(self.with_fragments(unmatched.pop(best), expected[track.track_id], unmatched),
                              frame_index)
        self.merged(expected, sharing, frame_index)
        self.parted(unmatched, expected, sharing, frame_index)
        self.hidden(expected, sharing, frame_index)
        for box in unmatched:
            track = VehicleTrack(self._next_id, TrackVotes(self.vote_frames, self.vote_policy))
            track.observe(box, frame_index)
            self.tracks.append(track)
            self._next_id += 1
        seen, stopped, removed, kept = [], [], [], []
        for track in self.tracks:
            track.shared_box = sharing.get(track.track_id)
            track.shared_frames = track.shared_frames + 1 if track.shared_box is not None else 0
            if track.last_frame == frame_index:
                track.state = TrackState.NEW if len(track.frames) == 1 else TrackState.TRACKED
                seen.append(track)
                if track.stopped_at_frame is None and self.is_still(track):
                    track.stopped_at_frame = frame_index
                    stopped.append(track)
            elif (track.shared_frames > self.params.max_shared_frames
                  or (track.shared_box is None
                      and frame_index - track.last_accounted_frame >= self.params.max_lost_frames)):
                track.state = TrackState.REMOVED
                removed.append(track)
                continue
            else:
                track.state = TrackState.LOST
            kept.append(track)
        self.tracks = kept
        return TrackerUpdate(seen, stopped, removed)

    def with_fragments(self, box: Box, expected: Box, unmatched: list[Box]) -> Box:
        """`box` joined with the boxes left over that are fragments of the same vehicle (taken out of `unmatched`):
        those lying at least `fragment_min_inside` inside where the track should be, joined when together they
        restore that box (IoU above `fragment_min_iou`, and above `box`'s own). A standing vehicle of the road's
        colour breaks into blobs (a grey body over grey asphalt keeps its windows and its lower edge apart), and its
        box would jump between them. Off by default (`fragment_min_iou` 1): in dense traffic seen small, parts of
        passing vehicles restored boxes too."""
        inside = [b for b in unmatched
                  if b.intersection(expected).area_px >= self.params.fragment_min_inside * b.area_px]
        if not inside:
            return box
        joined = box
        for fragment in inside:
            joined = joined.union(fragment)
        if joined.iou(expected) <= max(self.params.fragment_min_iou, box.iou(expected)):
            return box
        unmatched[:] = [b for b in unmatched if b not in inside]
        return joined

    def still_shared(self, boxes: list[Box]) -> tuple[list[Box], dict[int, Box]]:
        """The boxes not shared, and each sharing track's shared box: the tracks that shared a box in the last frame
        go on sharing the one box that overlaps it (two or more: the blob has parted)."""
        if self.params.max_shared_frames == 0:
            return boxes, {}
        groups: dict[Box, list[VehicleTrack]] = {}
        for track in self.tracks:
            if track.shared_box is not None:
                groups.setdefault(track.shared_box, []).append(track)
        sharing: dict[int, Box] = {}
        shared: set[int] = set()
        for previous, members in groups.items():
            within = [i for i, box in enumerate(boxes) if not box.intersection(previous).is_empty]
            if len(within) == 1:
                shared.add(within[0])
                sharing |= {t.track_id: boxes[within[0]] for t in members}
        return [box for i, box in enumerate(boxes) if i not in shared], sharing

    def merged(self, expected: dict[int, Box], sharing: dict[int, Box], frame_index: int) -> None:
        """A live track that found no box of its own, where a box another track took this frame covers at least
        `shared_min_cover` of where it should be, shares that box with it: their blobs have merged, and the box is
        neither's (the other track's observation of it is taken back). Adds to `sharing`."""
        if self.params.max_shared_frames == 0:
            return
        taken = [t for t in self.tracks if t.last_frame == frame_index]
        for track in self.tracks:
            if (track.last_frame == frame_index or track.track_id in sharing
                    or frame_index - track.last_frame >= self.params.max_lost_frames):
                continue
            cover = [t for t in taken  # a track that gave its box back this frame no longer covers
                     if t.last_frame == frame_index and self.covers(t.box, expected[track.track_id])]
            if cover:
                box = cover[0].unobserve()
                sharing |= {track.track_id: box, cover[0].track_id: box}
        shared = set(sharing.values())
        for track in self.tracks:  # a third track that took a shared box this frame shares it too
            if track.last_frame == frame_index and track.box in shared:
                sharing[track.track_id] = track.unobserve()

    def covers(self, box: Box, where: Box) -> bool:
        """Whether `box` covers at least `shared_min_cover` of `where` (where a track should be)."""
        return box.intersection(where).area_px >= self.params.shared_min_cover * where.area_px

    def hidden(self, expected: dict[int, Box], sharing: dict[int, Box], frame_index: int) -> None:
        """A track missed this frame, where a box another track took covers at least `shared_min_cover` of where it
        should be, is hidden in that vehicle's blob: the frame is one of its `hidden_frames` (its lost frames count
        from the last frame it was seen or hidden in), for at most `max_hidden_frames` frames since it was last seen."""
        if self.params.max_hidden_frames == 0:
            return
        taken = [t.box for t in self.tracks if t.last_frame == frame_index]
        for track in self.tracks:
            if (track.last_frame == frame_index or track.track_id in sharing
                    or frame_index - track.last_frame > self.params.max_hidden_frames
                    or frame_index - track.last_accounted_frame >= self.params.max_lost_frames):
                continue
            cover = [box for box in taken if self.covers(box, expected[track.track_id])]
            if cover:
                track.hidden_frames.append(frame_index)
                track.hidden_boxes.append(cover[0])

    def parted(self, unmatched: list[Box], expected: dict[int, Box], sharing: dict[int, Box],
               frame_index: int) -> None:
        """The tracks that shared a box in the last frame and have none now take the boxes left within it, the
        nearest to where each should be first (taken out of `unmatched`)."""
        waiting = [t for t in self.tracks if t.shared_box is not None and t.track_id not in sharing
                   and t.last_frame != frame_index]
        pairs = sorted((float(np.linalg.norm(b.centre_px - expected[t.track_id].centre_px)), i, t.track_id)
                       for t in waiting for i, b in enumerate(unmatched) if not b.intersection(t.shared_box).is_empty)
        taken_boxes, taken_tracks = set(), set()
        tracks = {t.track_id: t for t in waiting}
        for _, i, track_id in pairs:
            if i not in taken_boxes and track_id not in taken_tracks:
                tracks[track_id].observe(unmatched[i], frame_index)
                taken_boxes.add(i)
                taken_tracks.add(track_id)
        unmatched[:] = [b for i, b in enumerate(unmatched) if i not in taken_boxes]

    def is_still(self, track: VehicleTrack) -> bool:
        """Whether the track's box stayed put over its last `stop_frames` frames, seen one after another: its middle
        within `stop_tolerance_fraction` of its diagonal of where it is now, at the window's first frame and at all but
        `stop_flicker_frames` of the others (`still_but_for_flicker`). Where its top or its bottom flickers
        (strays from a smooth motion by more than half that, and more than half a step of the boxes' edges, which a
        smooth motion strays by on their grid: a standing car's shadow comes and goes from the foreground, a grey roof
        fades into the road) and the other does not, the middle is taken at the other's height, unless that one lies
        on the frame's edge (a vehicle coming in over it: the edge holds the box still). Its left and right sides are
        always taken together (the same rule for them called a car on the 320x240 highway clip still while its path
        said it moved, and turned its record 7 deg off the lane)."""
        n = self.params.stop_frames
        if len(track.boxes) < n or track.frames[-1] - track.frames[-n] != n - 1:
            return False
        edges = np.array([[b.x0, b.y0, b.x1, b.y1] for b in track.boxes[-n:]], dtype=float)
        shifts = edges - edges[-1]
        tolerance_px = self.params.stop_tolerance_fraction * np.hypot(track.box.width_px, track.box.height_px)
        flicker_tolerance_px = max(tolerance_px, self.box_step_px) / 2.0
        x_shift = shifts[:, [0, 2]].mean(axis=1)
        y_shift = steady_middle_shift(edges[:, [1, 3]], shifts[:, [1, 3]], flicker_tolerance_px, self.frame_height_px)
        return still_but_for_flicker(np.hypot(x_shift, y_shift) <= tolerance_px, self.params.stop_flicker_frames)


def still_but_for_flicker(within: np.ndarray, flicker_frames: int) -> bool:
    """Whether a window of frames, each flagged where the box's middle is within the stillness tolerance of the last
    frame's, shows a standing vehicle: its first frame within (the window's ends agree) and at most `flicker_frames`
    frames not (a box that strays for a frame or two and comes back: a shadow on a bright line beside the vehicle,
    a far grey car's side, flickering in and out of its blob). A moving or slowing vehicle strays from the window's
    first frame on, which no count forgives."""
    return bool(within[0]) and int(np.count_nonzero(~within)) <= flicker_frames


def steady_middle_shift(edges_px: np.ndarray, shifts_px: np.ndarray, flicker_tolerance_px: float,
                        frame_extent_px: int | None) -> np.ndarray:
    """A box's middle's shift along one axis over frames, from its two sides' positions and shifts (frames x 2): the
    mean of the two, or the steady side's shift where the other flickers (strays from its smooth motion by more than
    `flicker_tolerance_px`) and the steady one does not touch the frame's edge (0 or `frame_extent_px`, when known)."""
    flicker = flicker_px(shifts_px) > flicker_tolerance_px
    if flicker[0] != flicker[1]:
        steady = 1 if flicker[0] else 0
        held = frame_extent_px is not None and bool(
            np.any(edges_px[:, steady] <= 0) or np.any(edges_px[:, steady] >= frame_extent_px))
        if not held:
            return shifts_px[:, steady]
    return shifts_px.mean(axis=1)


def flicker_px(series: np.ndarray) -> np.ndarray:
    """How far each column of `series` (frames x columns) strays from its least-squares parabola (px): a smooth
    motion, steady or speeding up in the image as a vehicle nears, strays little; an edge that comes and goes, far."""
    t = np.arange(len(series), dtype=float)
    design = np.column_stack([t * t, t, np.ones_like(t)])
    coefficients, *_ = np.linalg.lstsq(design, series, rcond=None)
    return np.max(np.abs(series - design @ coefficients), axis=0)
