"""Traffic scenes with exact ground truth: a fixed elevated camera over a marked road, and catalog cars that
drive in and either stop at a target pose or pass through the view.

A scene is a video (empty frames first, for the background model; then the cars, each entering
``delay_frames`` after the empty ones: a stopping car decelerates to a stop at its target pose and stays
there, a passing car crosses its target pose at constant speed and leaves) and a ground-truth JSON: camera
intrinsics and pose, the road homography, every marker corner in world and image coordinates, and for
every car its model, dimensions, target pose, tyre contact points, footprint corners and plates there, and
its pose and box in every frame (`vehloc.geometry.truth` reads it).
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from itertools import islice
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from vehloc.atomic import atomic_paths
from vehloc.config import SettingError, build_params, check_range
from vehloc.data.boxes import Box
from vehloc.errors import VehlocError
from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.catalog import CATALOG, RGB, CarModel, model_by_id
from vehloc.synth.noise import SensorNoise
from vehloc.synth.render import (
    HEADING_CONVENTION,
    CarPose,
    Lighting,
    footprint_car_mm,
    plates_seen,
    render_car,
    tyre_contacts_car_mm,
)
from vehloc.synth.road import RoadLayout, render_road

CODECS = {"lossless": "FFV1", "mjpeg": "MJPG"}  # mjpeg: FFmpeg's encoder at its own quality (36-40 dB PSNR on scenes)
MIN_IMAGE_SIDE_PX, MAX_IMAGE_SIDE_PX = 16, 8192
MAX_FRAMES = 100_000
BOX_CONVENTION = (
    "0-based inclusive x1 y1 x2 y2 of the pixels the car covers at least half, each car's box as if it were "
    "alone (parts hidden by a nearer car included); null while the car is absent, out of view or partly "
    "behind the camera"
)
MOTION_CONVENTION = (
    "a car enters at entry_frame, approach_mm before target_pose along its heading; a stopping car "
    "decelerates evenly and stands at target_pose from stop_frame on; a passing car keeps the speed a "
    "stopping one enters with (2 approach_mm per drive_frames; its own speed_kmh where it has one), crosses "
    "target_pose at mid-time and leaves approach_mm after it; poses are null while a car is not in the scene"
)


class SceneError(VehlocError):
    """A scene cannot be written."""


@dataclass(frozen=True)
class CameraSpec:
    """A fixed camera: position (mm), the road point it looks at (mm), focal length and image size."""

    position_mm: tuple[float, float, float]
    target_mm: tuple[float, float, float]
    focal_px: float
    width_px: int
    height_px: int
    roll_deg: float

    def __post_init__(self) -> None:
        check_range("focal_px", self.focal_px, 0.0, low_open=True)
        check_range("width_px", self.width_px, MIN_IMAGE_SIDE_PX, MAX_IMAGE_SIDE_PX)
        check_range("height_px", self.height_px, MIN_IMAGE_SIDE_PX, MAX_IMAGE_SIDE_PX)
        if tuple(self.position_mm) == tuple(self.target_mm):
            raise SettingError("target_mm", "is the camera's position; the camera must look somewhere else")

    def camera(self) -> PinholeCamera:
        return PinholeCamera.look_at(
            self.position_mm, self.target_mm, self.focal_px, self.width_px, self.height_px, self.roll_deg
        )


@dataclass(frozen=True)
class CarSpec:
    """One car of a scene: a catalog model and paint, its target pose, the distance it drives to reach it,
    whether it stops there (else it passes through at constant speed), how many frames after the
    empty ones it enters, whether it carries licence plates, and a passing car's own speed (else the one a
    stopping car enters with)."""

    model_id: int
    colour_index: int
    target_x_mm: float
    target_y_mm: float
    target_heading_deg: float
    approach_mm: float
    stops: bool
    delay_frames: int
    plates: bool = True
    speed_kmh: float | None = None

    def __post_init__(self) -> None:
        if self.speed_kmh is not None:
            check_range("speed_kmh", self.speed_kmh, 0.0, 400.0, low_open=True)
            if self.stops:
                raise ValueError("speed_kmh is a passing car's own speed: a stopping car (stops: true) has none")
        ids = [m.model_id for m in CATALOG]
        if self.model_id not in ids:
            raise ValueError(f"model_id {self.model_id} is not a catalog model ({min(ids)} to {max(ids)})")
        if self.colour_index < 0:
            raise ValueError(f"colour_index must be >= 0, got {self.colour_index}")
        if self.approach_mm <= 0:
            raise ValueError(f"approach_mm must be positive, got {self.approach_mm}")
        if self.delay_frames < 0:
            raise ValueError(f"delay_frames must be >= 0, got {self.delay_frames}")
        if self.delay_frames > MAX_FRAMES:
            raise ValueError(f"delay_frames must be <= {MAX_FRAMES}, got {self.delay_frames}")

    @property
    def target_pose(self) -> CarPose:
        return CarPose(self.target_x_mm, self.target_y_mm, self.target_heading_deg)

    def drive_frames(self, scene_drive_frames: int, fps: float) -> int:
        """Frames from entering to stopping, or to leaving for a passing car (its own speed's where it has one)."""
        if self.speed_kmh is None:
            return scene_drive_frames
        return int(np.ceil(2.0 * self.approach_mm / (self.speed_kmh / 3.6) * fps / 1000.0))

    @property
    def model(self) -> CarModel:
        return model_by_id(self.model_id)

    @property
    def paint(self) -> tuple[str, RGB]:
        """The colour's name and RGB: entry `colour_index` of the model's palette, counted round."""
        palette = self.model.palette
        return palette[self.colour_index % len(palette)]


@dataclass(frozen=True)
class SceneSpec:
    """Everything that defines a rendered traffic scene (a `conf/scene/` config): camera, road, cars,
    timing, light, sensor noise, codec and seed, and where the speed truth's measurement lines cross the road
    (none: no speed truth)."""

    name: str
    camera: CameraSpec
    layout: RoadLayout
    cars: tuple[CarSpec, ...]
    empty_frames: int
    drive_frames: int
    stopped_frames: int
    fps: float
    light_azimuth_deg: float
    light_elevation_deg: float
    noise_sigma: float
    codec: str
    seed: int
    measurement_lines_y_mm: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.measurement_lines_y_mm and len(self.measurement_lines_y_mm) < 2:
            raise ValueError("measurement_lines_y_mm: the speed truth needs at least two measurement lines")
        if not self.cars:
            raise ValueError("cars: a scene needs at least one car")
        check_range("empty_frames", self.empty_frames, 0, MAX_FRAMES)
        check_range("stopped_frames", self.stopped_frames, 0, MAX_FRAMES)
        check_range("drive_frames", self.drive_frames, 1, MAX_FRAMES)
        check_range("fps", self.fps, 0.0, 1000.0, low_open=True)
        check_range("noise_sigma", self.noise_sigma, 0.0, 100.0)
        check_range("light_elevation_deg", self.light_elevation_deg, 0.0, 90.0, low_open=True)
        if self.codec not in CODECS:
            raise ValueError(f"codec must be one of {sorted(CODECS)}, got {self.codec!r}")
        if self.frame_count > MAX_FRAMES:
            raise ValueError(f"the scene would have {self.frame_count} frames; at most {MAX_FRAMES}")

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> SceneSpec:
        """Build from a plain mapping (a composed scene config); ConfigError naming a bad setting."""
        return build_params(cls, values, "scene")

    @property
    def frame_count(self) -> int:
        """Empty frames, until the last car stops or leaves, then the stopped frames."""
        last = max(car.delay_frames + car.drive_frames(self.drive_frames, self.fps) for car in self.cars)
        return self.empty_frames + last + self.stopped_frames

    def entry_frame(self, car: CarSpec) -> int:
        """First frame with `car` in the scene."""
        return self.empty_frames + car.delay_frames

    def stop_frame(self, car: CarSpec) -> int | None:
        """First frame at which `car` stands at its target pose; None for a passing car."""
        return self.entry_frame(car) + self.drive_frames if car.stops else None


def car_pose_at(spec: SceneSpec, car: CarSpec, frame: int) -> CarPose | None:
    """The car's pose in a frame, None while it is not in the scene (see `MOTION_CONVENTION`)."""
    elapsed = frame - spec.entry_frame(car)
    if elapsed < 0:
        return None
    if car.stops:
        if elapsed >= spec.drive_frames:
            return car.target_pose
        offset_mm = -car.approach_mm * (1.0 - elapsed / spec.drive_frames) ** 2
    elif car.speed_kmh is not None:
        offset_mm = car.speed_kmh / 3.6 * 1000.0 * elapsed / spec.fps - car.approach_mm
        if offset_mm > car.approach_mm:
            return None
    else:
        if elapsed > spec.drive_frames:
            return None
        offset_mm = car.approach_mm * (2.0 * elapsed / spec.drive_frames - 1.0)
    heading = np.radians(car.target_heading_deg)
    return CarPose(
        car.target_x_mm + offset_mm * np.cos(heading),
        car.target_y_mm + offset_mm * np.sin(heading),
        car.target_heading_deg,
    )


def draw_cars(
    cars: Sequence[CarSpec],
    poses: Sequence[CarPose | None],
    camera: PinholeCamera,
    background_bgr: np.ndarray,
    lighting: Lighting,
) -> tuple[np.ndarray, tuple[Box | None, ...]]:
    """The cars that have a pose drawn farthest first, each over what is drawn so far, and each car's box as
    if it were alone (None when it is absent, out of view or partly behind the camera's near plane)."""
    image, boxes = background_bgr, [None] * len(cars)
    centre_mm = camera.centre_mm
    present = [i for i, pose in enumerate(poses) if pose is not None]
    present.sort(key=lambda i: -float(np.linalg.norm([poses[i].x_mm, poses[i].y_mm, 0.0] - centre_mm)))
    for i in present:
        try:
            render = render_car(cars[i].model, cars[i].paint[1], poses[i], camera, image, lighting,
                                plates=cars[i].plates)
        except ValueError:  # the car is not yet entirely in front of the camera
            continue
        image, boxes[i] = render.image_bgr, render.box
    return image, tuple(boxes)


def scene_lighting(spec: SceneSpec) -> Lighting:
    """The scene's sun, as its frames are lit."""
    return Lighting.from_angles(spec.light_azimuth_deg, spec.light_elevation_deg, 0.45, 0.6)


def render_frames(spec: SceneSpec) -> Iterator[tuple[np.ndarray, tuple[Box | None, ...]]]:
    """Yield every frame of the scene with the box of each car of `spec.cars` (None where it has none).
    The road is drawn once; frames whose cars stand where they stood in the previous frame reuse its
    drawing under fresh noise."""
    camera = spec.camera.camera()
    rng = np.random.default_rng(spec.seed)
    background = render_road(camera, spec.layout, rng)
    lighting = scene_lighting(spec)
    noise = SensorNoise(spec.noise_sigma, rng)
    drawn_poses: tuple[CarPose | None, ...] | None = None
    for frame in range(spec.frame_count):
        poses = tuple(car_pose_at(spec, car, frame) for car in spec.cars)
        if poses != drawn_poses:
            image, boxes = draw_cars(spec.cars, poses, camera, background, lighting)
            drawn_poses = poses
        yield noise(image), boxes


def _pose_truth(pose: CarPose) -> dict[str, float]:
    return {"x_mm": float(pose.x_mm), "y_mm": float(pose.y_mm), "heading_deg": float(pose.heading_deg)}


def _car_truth(spec: SceneSpec, car: CarSpec, camera: PinholeCamera, boxes: Sequence[Box | None]) -> dict:
    """One car's entry of the ground truth: what it is, where it stops or crosses, and where it is in every frame."""
    model, pose = car.model, car.target_pose
    contacts_mm = pose.car_to_world(tyre_contacts_car_mm(model))
    corners_mm = pose.car_to_world(footprint_car_mm(model))
    first = spec.entry_frame(car)
    last = spec.frame_count if car.stops else min(spec.frame_count, first + car.drive_frames(spec.drive_frames, spec.fps) + 1)
    poses = [car_pose_at(spec, car, frame) for frame in range(first, last)]
    return {
        "model_id": model.model_id,
        "make": model.make,
        "model": model.name,
        "colour": car.paint[0],
        "length_mm": model.length_mm,
        "width_mm": model.width_mm,
        "height_mm": model.height_mm,
        "wheelbase_mm": model.wheelbase_mm,
        "axle_middle_x_mm": (model.front_axle_x_mm + model.rear_axle_x_mm) / 2,
        "stops": car.stops,
        "speed_kmh": None if car.stops else (car.speed_kmh if car.speed_kmh is not None
                                             else 2.0 * car.approach_mm / spec.drive_frames * spec.fps * 3.6e-3),
        "entry_frame": spec.entry_frame(car),
        "stop_frame": spec.stop_frame(car),
        "target_pose": _pose_truth(pose),
        "tyre_contacts_mm": contacts_mm[:, :2].tolist(),
        "tyre_contacts_px": camera.project(contacts_mm).tolist(),
        "tyre_order": ["front_left", "front_right", "rear_left", "rear_right"],
        "footprint_corners_mm": corners_mm[:, :2].tolist(),
        "footprint_corners_px": camera.project(corners_mm).tolist(),
        "footprint_order": ["front_left", "front_right", "rear_right", "rear_left"],
        "plates": {
            end: {"corners_mm": plate.corners_mm.tolist(), "corners_px": plate.corners_px.tolist(),
                  "centre_px": camera.project(plate.centre_mm[None])[0].tolist(), "faces_camera": plate.faces_camera}
            for end, plate in (plates_seen(model, pose, camera) if car.plates else {}).items()
        },
        "plate_corner_order": "counter-clockwise seen from outside the car, from the lower corner on its right",
        "per_frame_from": first,
        "poses": [None if p is None else _pose_truth(p) for p in poses],
        "boxes_xyxy_px": [None if box is None else list(box.to_inclusive()) for box in boxes[first:last]],
    }


def ground_truth(spec: SceneSpec, boxes: Sequence[Sequence[Box | None]]) -> dict:
    """The scene's ground truth as a JSON-ready mapping; `boxes` holds every frame's boxes, one per car."""
    camera = spec.camera.camera()
    homography = camera.road_to_image().normalised_matrix
    markers = []
    for marker in spec.layout.markers():
        corners_px = camera.project(np.column_stack([marker.corners_mm, np.zeros(len(marker.corners_mm))]))
        markers.append(
            {
                "id": marker.marker_id,
                "colour": marker.colour,
                "has_corners": marker.has_corners,
                "corners_mm": marker.corners_mm.tolist(),
                "corners_px": [None if not np.all(np.isfinite(p)) else p.tolist() for p in corners_px],
            }
        )
    return {
        "scene": spec.name,
        "spec": asdict(spec),
        "heading_convention": HEADING_CONVENTION,
        "frames": spec.frame_count,
        "fps": spec.fps,
        "empty_frames": spec.empty_frames,
        "camera": {
            "K": camera.K.tolist(),
            "R_world_to_camera": camera.R.tolist(),
            "t_mm": camera.t.tolist(),
            "centre_mm": camera.centre_mm.tolist(),
            "width_px": camera.width_px,
            "height_px": camera.height_px,
        },
        "homography_world_mm_to_image_px": homography.tolist(),
        "markers": markers,
        "motion_convention": MOTION_CONVENTION,
        "box_convention": BOX_CONVENTION,
        "cars": [
            _car_truth(spec, car, camera, [frame_boxes[index] for frame_boxes in boxes])
            for index, car in enumerate(spec.cars)
        ],
    }


def write_video(spec: SceneSpec, path: Path, frame_count: int | None = None) -> list[tuple[Box | None, ...]]:
    """Render the scene, or its first `frame_count` frames (the same as the whole scene's), into a video file (its
    `codec`; the container by the path's suffix); return every written frame's car boxes."""
    size = (spec.camera.width_px, spec.camera.height_px)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*CODECS[spec.codec]), spec.fps, size)
    if not writer.isOpened():
        raise SceneError(f"{path}: OpenCV cannot write {CODECS[spec.codec]} video")
    boxes = []
    try:
        for frame, frame_boxes in islice(render_frames(spec), frame_count):
            writer.write(frame)
            boxes.append(frame_boxes)
    finally:
        writer.release()
    return boxes


def check_cars_in_view(spec: SceneSpec) -> None:
    """SceneError naming the car when a car's footprint at its target pose lies wholly outside the image or
    behind the camera: a scene of it would be a video without it."""
    camera = spec.camera.camera()
    for index, car in enumerate(spec.cars):
        corners_mm = car.target_pose.car_to_world(footprint_car_mm(car.model))
        in_front = camera.to_camera(corners_mm)[:, 2] > 0
        pixels = camera.project(corners_mm)
        inside = (in_front & np.all(np.isfinite(pixels), axis=1) & (pixels[:, 0] >= 0) & (pixels[:, 0] < camera.width_px)
                  & (pixels[:, 1] >= 0) & (pixels[:, 1] < camera.height_px))
        if not inside.any():
            raise SceneError(
                f"scene.cars[{index}]: at its target pose ({car.target_x_mm:g}, {car.target_y_mm:g}) mm the car is "
                "not in the camera's view"
            )


def write_scene(spec: SceneSpec, out_dir: Path, site_yaml: str | None = None) -> tuple[Path, Path]:
    """Render a scene to `out_dir/video.avi` and `out_dir/ground_truth.json` (and `site_yaml`, the text of its
    site file, to `out_dir/site.yaml`; with measurement lines, the speed benchmark's ground truth to
    `out_dir/gt_data.json`); return the video's and the truth's paths. Every file is written to a
    temporary sibling first, and they all replace their targets together when the last is complete, so an
    interrupt or a failure leaves an earlier scene in `out_dir` whole and matching."""
    from vehloc.synth.speed_truth import speed_ground_truth

    check_cars_in_view(spec)
    video_path, truth_path = out_dir / "video.avi", out_dir / "ground_truth.json"
    extra = {"site.yaml": site_yaml} if site_yaml is not None else {}
    if spec.measurement_lines_y_mm:
        extra["gt_data.json"] = json.dumps(speed_ground_truth(spec, str(video_path)), indent=1)
    targets = [video_path, truth_path] + [out_dir / name for name in extra]
    with atomic_paths(targets) as temporaries:
        staged = temporaries[0].with_name(temporaries[0].name + video_path.suffix)  # OpenCV picks the container by suffix
        try:
            boxes = write_video(spec, staged)
            staged.replace(temporaries[0])
        finally:
            staged.unlink(missing_ok=True)
        temporaries[1].write_text(json.dumps(ground_truth(spec, boxes), indent=1), encoding="utf-8")
        for temporary, text in zip(temporaries[2:], extra.values()):
            temporary.write_text(text, encoding="utf-8")
    return video_path, truth_path
