"""The tracker's lifecycle: a track is new in its first frame, tracked while seen, lost while missed, and removed,
with everything it holds, once it has been missed in `max_lost_frames` frames in a row; a vehicle seen again
within that gap keeps its track."""

from __future__ import annotations

from vehloc.data.boxes import Box
from vehloc.geometry.pipeline.tracker import StoppedVehicleTracker, TrackerParams, TrackState

BOX = Box(100, 100, 160, 140)


def tracker(max_lost_frames: int = 3) -> StoppedVehicleTracker:
    return StoppedVehicleTracker(vote_frames=4, params=TrackerParams.from_config(max_lost_frames=max_lost_frames))


def test_a_track_goes_new_tracked_lost_removed() -> None:
    t = tracker(max_lost_frames=3)
    first = t.update([BOX], 0)
    (track,) = first.seen
    assert track.state is TrackState.NEW and first.removed == []
    assert t.update([BOX], 1).seen == [track] and track.state is TrackState.TRACKED
    states = []
    for frame in (2, 3):
        update = t.update([], frame)
        states.append(track.state)
        assert update.seen == [] and update.removed == [] and t.tracks == [track]
    assert states == [TrackState.LOST, TrackState.LOST]
    update = t.update([], 4)  # missed in frames 2, 3 and 4: three in a row
    assert update.removed == [track] and track.state is TrackState.REMOVED and t.tracks == []


def test_a_vehicle_seen_again_within_the_gap_keeps_its_track() -> None:
    t = tracker(max_lost_frames=3)
    (track,) = t.update([BOX], 0).seen
    t.update([], 1)
    t.update([], 2)
    assert t.update([BOX], 3).seen == [track]  # missed twice, seen again: the same track
    assert track.frames == [0, 3] and track.state is TrackState.TRACKED


def test_a_vehicle_seen_after_the_gap_starts_a_new_track() -> None:
    t = tracker(max_lost_frames=2)
    (old,) = t.update([BOX], 0).seen
    t.update([], 1)
    assert t.update([], 2).removed == [old]
    (new,) = t.update([BOX], 3).seen
    assert new.track_id != old.track_id and new.state is TrackState.NEW and t.tracks == [new]


def test_the_tracker_holds_only_the_tracks_in_view() -> None:
    """A thousand vehicles, each in view for 20 frames, a new one every 10 frames in one of three places: the tracker
    never holds more than the two in view and the one just lost, and removes every other one."""
    t = tracker(max_lost_frames=3)
    removed, held = 0, []
    for frame in range(10_000):
        boxes = [Box(200 * (v % 3), 300, 200 * (v % 3) + 40, 330) for v in (frame // 10 - 1, frame // 10)
                 if 0 <= v and frame - 10 * v < 20]
        update = t.update(boxes, frame)
        removed += len(update.removed)
        held.append(len(t.tracks))
    assert max(held) <= 3
    assert removed == 998 and [track.track_id for track in t.tracks] == [999, 1000]  # the last two still in view
    assert t.started == 1000
