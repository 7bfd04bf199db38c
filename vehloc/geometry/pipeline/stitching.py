"""One vehicle, two tracks: where a track lost its vehicle (hidden in another's blob, its track gone on to the other
vehicle when the blobs parted) a new track starts on it. Their two measured paths are joined where the later one
starts where the earlier one's steady motion puts the vehicle then, the earlier one ends where the later one's puts
it, and their speeds agree: the road's frame tells it far better than the boxes in the image did. A track measured by
its box's bottom (its nearest end) is compared with one measured by its model's shape (its centre) moved half the
model's length to its centre; joined, the vehicle is measured on the shape's points only."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from vehloc.geometry.outcome import NotPlaced
from vehloc.geometry.pipeline.track_speed import StitchParams, VehiclePath, VehicleSpeed
from vehloc.geometry.speed import SpeedFit

ToCentre = Callable[[VehicleSpeed, float], VehicleSpeed]
"""A vehicle measured by its box's bottom as one of the given length (mm) measured at its centre would be."""


def by_box_bottom(vehicle: VehicleSpeed) -> bool:
    """Whether its path is the road point under its box's bottom (its nearest end), not its centre."""
    return vehicle.reference == "box_bottom"


def as_each_other(a: VehicleSpeed, b: VehicleSpeed, to_centre: ToCentre) -> tuple[VehicleSpeed, VehicleSpeed]:
    """Two vehicles with their paths on the same point of a vehicle: one measured by its box's bottom moved to its
    centre by the other's length, where the other is measured at its centre (by its model's shape)."""
    if by_box_bottom(a) and not by_box_bottom(b) and b.dims_mm is not None:
        return to_centre(a, b.dims_mm[0]), b
    if by_box_bottom(b) and not by_box_bottom(a) and a.dims_mm is not None:
        return a, to_centre(b, a.dims_mm[0])
    return a, b


def used_path(vehicle: VehicleSpeed) -> tuple[np.ndarray, np.ndarray]:
    """The frames (N,) and road points (N, 2) mm its speed used."""
    return vehicle.path.frames[vehicle.used], vehicle.path.points_mm[vehicle.used]


def offset_mm(earlier: VehicleSpeed, later: VehicleSpeed, ends_points: int) -> float:
    """How far apart two measured paths meet (mm): the larger of the median distances of the later path's first
    `ends_points` points from the earlier one's steady motion and of the earlier path's last points from the later
    one's."""
    first_frames, first_points = (a[:ends_points] for a in used_path(later))
    last_frames, last_points = (a[-ends_points:] for a in used_path(earlier))
    ahead = np.linalg.norm(first_points - earlier.speed.positions_mm(first_frames / earlier.fps), axis=1)
    back = np.linalg.norm(last_points - later.speed.positions_mm(last_frames / later.fps), axis=1)
    return float(max(np.median(ahead), np.median(back)))


def speeds_agree(a: SpeedFit, b: SpeedFit, max_difference_fraction: float) -> bool:
    """Whether two speeds differ by at most `max_difference_fraction` of the faster."""
    slower, faster = sorted((a.speed_kmh, b.speed_kmh))
    return faster - slower <= max_difference_fraction * faster


def stitch(vehicles: Sequence[VehicleSpeed], params: StitchParams,
           refit: Callable[[VehiclePath], SpeedFit | NotPlaced], to_centre: ToCentre) -> list[VehicleSpeed]:
    """The vehicles with each pair of measured tracks that are one vehicle joined (`joined`): the later path begins
    within `max_gap_s` after the earlier ends, their speeds agree (`max_speed_difference_fraction`) and they meet
    within `max_offset_mm` (`offset_mm`, as `as_each_other`); the closest pairs first, each track joined once at each
    end, chains joined whole. `refit` measures the joined path's speed."""
    frames = {v.track_id: used_path(v)[0] for v in vehicles if isinstance(v.speed, SpeedFit)}
    measured = sorted((v for v in vehicles if v.track_id in frames), key=lambda v: frames[v.track_id][0])
    starts = np.array([frames[v.track_id][0] for v in measured])
    pairs = []
    for a in measured:
        last = frames[a.track_id][-1]
        after = measured[int(np.searchsorted(starts, last, side="right")):
                         int(np.searchsorted(starts, last + params.max_gap_s * a.fps, side="right"))]
        pairs += [(offset_mm(*as_each_other(a, b, to_centre), params.ends_points), a.track_id, b.track_id)
                  for b in after if speeds_agree(a.speed, b.speed, params.max_speed_difference_fraction)]
    pairs.sort()
    by_id = {v.track_id: v for v in vehicles}
    next_of: dict[int, int] = {}
    previous_of: dict[int, int] = {}
    for distance, a_id, b_id in pairs:
        if distance <= params.max_offset_mm and a_id not in next_of and b_id not in previous_of:
            next_of[a_id], previous_of[b_id] = b_id, a_id
    result = []
    for vehicle in vehicles:
        if vehicle.track_id in previous_of:
            continue
        chain = [vehicle]
        while chain[-1].track_id in next_of:
            chain.append(by_id[next_of[chain[-1].track_id]])
        result.append(joined(chain, refit) if len(chain) > 1 else vehicle)
    return result


def joined(chain: Sequence[VehicleSpeed], refit: Callable[[VehiclePath], SpeedFit | NotPlaced]) -> VehicleSpeed:
    """One vehicle of the tracks of `chain` (in order): the first's id, the model of the one measured on the most
    points, their paths' used points together, measured again by `refit`, the frames each followed it in until the next
    took over, and the ids of all (`joined_track_ids`). Where some were measured by their model's shape, only those
    are: the box's bottom is no fixed point of the vehicle (its shadow, its front seen ever more from above), and a
    track measured by it only says where the vehicle went on."""
    measured = [v for v in chain if not by_box_bottom(v)] or list(chain)
    longest = max(measured, key=lambda v: int(v.used.sum()))
    parts = [used_path(v) for v in measured]
    boxes = np.concatenate([v.path.boxes_px[v.used] for v in measured])
    points_px = np.concatenate([v.path.points_px[v.used] for v in measured])
    path = VehiclePath(np.concatenate([f for f, _ in parts]), np.concatenate([p for _, p in parts]), points_px, boxes)
    seen_frames, seen_boxes = [], []
    for vehicle, following in zip(chain, list(chain[1:]) + [None]):
        keep = np.ones(len(vehicle.seen_frames), bool) if following is None else (
            vehicle.seen_frames < following.seen_frames[0])
        seen_frames.append(vehicle.seen_frames[keep])
        seen_boxes.append(vehicle.seen_boxes_px[keep])
    return replace(longest, track_id=chain[0].track_id, first_frame=chain[0].first_frame, last_frame=chain[-1].last_frame,
                   path=path, speed=refit(path), seen_frames=np.concatenate(seen_frames),
                   seen_boxes_px=np.concatenate(seen_boxes), joined_track_ids=tuple(v.track_id for v in chain))
