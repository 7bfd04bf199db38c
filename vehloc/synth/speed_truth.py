"""A traffic scene's speed truth in the field's benchmark's format (BrnoCompSpeed's `gt_data`, as JSON): the
measurement lines across the road and the lane-dividing lines along it as homogeneous image lines, the distances
between marker ends (along the road, towards the first vanishing point, and across it), and every passing car's
lane, the video times its footprint centre crosses the measurement lines (in the order it crosses them) and its
speed. The measurement lines are listed last-crossed first, as the benchmark's scorer reads them."""

from __future__ import annotations

import numpy as np

from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.scene import CarSpec, SceneSpec


def image_line(camera: PinholeCamera, a_mm: np.ndarray, b_mm: np.ndarray) -> list[float]:
    """The homogeneous image line through two road points' pixels, scaled so that (a, b) is a unit normal."""
    pixels = camera.project(np.array([[*a_mm, 0.0], [*b_mm, 0.0]]))
    line = np.cross(np.append(pixels[0], 1.0), np.append(pixels[1], 1.0))
    return (line / np.linalg.norm(line[:2])).tolist()


def crossing_time_s(spec: SceneSpec, car: CarSpec, y_mm: float) -> float | None:
    """The video time (s) at which the car's footprint centre crosses the road line Y = `y_mm`; None for a car that
    does not cross it at a constant speed."""
    heading_sin = np.sin(np.radians(car.target_heading_deg))
    if car.stops or car.speed_kmh is None or abs(heading_sin) < 1e-9:
        return None
    offset_mm = (y_mm - car.target_y_mm) / heading_sin
    if abs(offset_mm) > car.approach_mm:
        return None
    elapsed_frames = (offset_mm + car.approach_mm) / (car.speed_kmh / 3.6 * 1000.0) * spec.fps
    return (spec.entry_frame(car) + elapsed_frames) / spec.fps


def lane_lines_x_mm(spec: SceneSpec) -> np.ndarray:
    """The road's edges and lane lines across it (mm), left to right."""
    half = spec.layout.road_width_mm / 2
    return -half + spec.layout.lane_width_mm * np.arange(spec.layout.lane_count + 1)


def speed_ground_truth(spec: SceneSpec, video: str) -> dict:
    """The scene's speed truth as a JSON-ready mapping (its cars must all pass at their own speeds)."""
    camera = spec.camera.camera()
    half_mm = spec.layout.road_width_mm / 2
    headings = {np.sign(np.sin(np.radians(car.target_heading_deg))) for car in spec.cars}
    lines_y = sorted(spec.measurement_lines_y_mm, reverse=headings == {1.0})  # last crossed first
    lane_x = lane_lines_x_mm(spec)
    near_y, far_y = min(lines_y), max(lines_y)
    distances = []
    for marker in spec.layout.markers():
        if marker.has_corners and marker.marker_id.startswith("lane") and near_y - 10000 <= marker.corners_mm[0, 1] <= far_y:
            start, end = marker.corners_mm[:2].mean(axis=0), marker.corners_mm[2:].mean(axis=0)
            pixels = camera.project(np.array([[*start, 0.0], [*end, 0.0]]))
            distances.append({"p1": [*pixels[0], 1.0], "p2": [*pixels[1], 1.0],
                              "distance": float(np.linalg.norm(end - start)) / 1000.0, "toVP1": True})
    for y_mm in lines_y:
        pixels = camera.project(np.array([[lane_x[0], y_mm, 0.0], [lane_x[-1], y_mm, 0.0]]))
        distances.append({"p1": [*pixels[0], 1.0], "p2": [*pixels[1], 1.0],
                          "distance": float(lane_x[-1] - lane_x[0]) / 1000.0, "toVP1": False})
    cars = []
    for index, car in enumerate(spec.cars):
        times = [crossing_time_s(spec, car, y) for y in lines_y[::-1]]
        if any(t is None for t in times):
            continue
        lane = int(np.searchsorted(lane_x, car.target_x_mm)) - 1
        cars.append({"carId": index, "laneIndex": [lane], "intersections": [
            {"measurementLineId": len(lines_y) - 1 - k, "videoTime": t} for k, t in enumerate(times)],
                     "speed": float(car.speed_kmh), "valid": 0 <= lane < spec.layout.lane_count})
    return {
        "video": video,
        "fps": spec.fps,
        "measurementLines": [image_line(camera, (-half_mm, y), (half_mm, y)) for y in lines_y],
        "laneDivLines": [image_line(camera, (x, near_y), (x, far_y)) for x in lane_x],
        "invalidLanes": [],
        "distanceMeasurement": distances,
        "cars": cars,
        "measurement_lines_y_mm": lines_y,
        "lane_lines_x_mm": lane_x.tolist(),
    }
