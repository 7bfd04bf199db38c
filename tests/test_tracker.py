"""The stopped-vehicle tracker on boxes whose motion is known exactly: when it says a vehicle stopped."""

from __future__ import annotations

import numpy as np

from vehloc.data.boxes import Box
from vehloc.geometry.roi import StoppedVehicleTracker, TrackerParams


def box_at(x_px: float, grow_px: int = 0) -> Box:
    """A 100 x 50 px vehicle box whose left edge is at `x_px` (diagonal 112 px: the stop tolerance is 2.2 px), its
    bottom `grow_px` lower (a shadow taken for the vehicle)."""
    return Box(int(round(x_px)), 300, int(round(x_px)) + 100, 350 + grow_px)


def stops(xs_px: list[float], grows_px: list[int] | None = None) -> list[int]:
    """The frames at which the tracker says the one vehicle, at these left edges frame by frame, stopped."""
    tracker = StoppedVehicleTracker(TrackerParams.from_config())
    grows_px = grows_px or [0] * len(xs_px)
    return [frame for frame, (x, grow) in enumerate(zip(xs_px, grows_px))
            for _ in tracker.update([box_at(x, grow)], frame)]


def test_a_vehicle_that_stops_is_said_to_stop_once_after_ten_still_frames() -> None:
    """It drives 10 px a frame for 20 frames and stands 30 (standing from frame 19): said once, at frame 28."""
    drive = [10.0 * i for i in range(20)]
    assert stops(drive + [drive[-1]] * 30) == [19 + 9]


def test_a_vehicle_creeping_faster_than_the_tolerance_is_not_still() -> None:
    """0.3 px a frame drifts 2.7 px over the 10-frame window, beyond the 2.2 px tolerance: never still."""
    assert stops([200.0 + 0.3 * i for i in range(40)]) == []


def test_a_standing_vehicle_whose_box_bottom_flickers_is_said_to_stop_once() -> None:
    """A standing vehicle whose box grows 6 px at its bottom in random frames (its centre jumps 3 px, beyond the
    2.2 px tolerance: a far car's shadow) is still: the line through the centres does not drift. Once, over 5
    random flicker patterns (the largest distance from the last centre, the rule before, called 0 of them still)."""
    for seed in range(5):
        grows = list(6 * np.random.default_rng(seed).integers(0, 2, 60))
        said = stops([400.0] * 60, grows)
        assert len(said) == 1 and said[0] <= 20, (seed, said)


def test_a_vehicle_that_creeps_on_after_looking_still_stops_again() -> None:
    """It creeps 0.2 px a frame (still to the tracker), then moves 8 px and stands: the tracker says it stopped
    twice, the second time after it really stood."""
    creep = [200.0 + 0.2 * i for i in range(12)]
    move = [creep[-1] + 2.0 * (i + 1) for i in range(4)]
    said = stops(creep + move + [move[-1]] * 20)
    assert len(said) == 2 and said[0] < 12
    assert said[1] >= 12 + len(move)


def test_a_still_vehicle_whose_box_jumps_once_is_not_stopped_again() -> None:
    """A box that jumps 5 px for one frame (beyond the 2.2 px tolerance) moves the window's mean centre by 0.5 px:
    not taken for a vehicle that moved on."""
    assert len(stops([400.0] * 15 + [405.0] + [400.0] * 20)) == 1
