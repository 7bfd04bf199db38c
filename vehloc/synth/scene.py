"""Traffic scenes with exact ground truth: a fixed elevated camera over a marked road, and a catalog
car that drives in and stops at a target pose.

A scene is a video (empty frames first, for the background model; then the car driving in along its
heading, decelerating to a stop; then the car standing still) and a ground-truth JSON: camera
intrinsics and pose, the road homography, every marker corner in world and image coordinates, the
car's model, dimensions and final pose, its tyre contact points and footprint corners, and its box
in every frame.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.catalog import model_by_id
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

CODECS = {"lossless": "FFV1", "mjpeg": "MJPG"}
MJPEG_QUALITY = 95


@dataclass(frozen=True)
class CameraSpec:
    """A fixed camera: position (mm), the road point it looks at (mm), focal length and image size."""

    position_mm: tuple[float, float, float] = (-2000.0, -7000.0, 6000.0)
    target_mm: tuple[float, float, float] = (0.0, 8000.0, 0.0)
    focal_px: float = 1000.0
    width_px: int = 1280
    height_px: int = 720
    roll_deg: float = 0.0

    def camera(self) -> PinholeCamera:
        return PinholeCamera.look_at(
            self.position_mm, self.target_mm, self.focal_px, self.width_px, self.height_px, self.roll_deg
        )


@dataclass(frozen=True)
class SceneSpec:
    """Everything that defines a rendered traffic scene."""

    name: str = "scene"
    camera: CameraSpec = field(default_factory=CameraSpec)
    layout: RoadLayout = field(default_factory=lambda: RoadLayout(start_y_mm=-3000.0, end_y_mm=80000.0))
    model_id: int = 9
    colour_index: int = 0
    target_x_mm: float = 0.0
    target_y_mm: float = 8000.0
    target_heading_deg: float = 0.0
    approach_mm: float = 12000.0
    empty_frames: int = 150
    drive_frames: int = 50
    stopped_frames: int = 30
    fps: float = 25.0
    light_azimuth_deg: float = 140.0
    light_elevation_deg: float = 50.0
    noise_sigma: float = 2.0
    codec: str = "mjpeg"
    seed: int = 0

    @classmethod
    def from_dict(cls, values: dict) -> SceneSpec:
        """Build from a plain mapping (a Hydra scene config)."""
        values = dict(values)
        camera = CameraSpec(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.pop("camera", {}).items()})
        layout = RoadLayout(**values.pop("layout", {}))
        unknown = set(values) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown scene setting(s): {', '.join(sorted(unknown))}")
        if values.get("codec", "lossless") not in CODECS:
            raise ValueError(f"codec must be one of {sorted(CODECS)}, got {values['codec']!r}")
        return cls(camera=camera, layout=layout, **values)

    @property
    def target_pose(self) -> CarPose:
        return CarPose(self.target_x_mm, self.target_y_mm, self.target_heading_deg)

    @property
    def frame_count(self) -> int:
        return self.empty_frames + self.drive_frames + self.stopped_frames

    @property
    def stop_frame(self) -> int:
        """First frame at which the car stands at its target pose."""
        return self.empty_frames + self.drive_frames


def car_pose_at(spec: SceneSpec, frame: int) -> CarPose | None:
    """The car's pose in a frame (None before it appears): constant deceleration to the target."""
    if frame < spec.empty_frames:
        return None
    progress = min(1.0, (frame - spec.empty_frames) / spec.drive_frames)
    remaining_mm = spec.approach_mm * (1.0 - progress) ** 2
    heading = np.radians(spec.target_heading_deg)
    return CarPose(
        spec.target_x_mm - remaining_mm * np.cos(heading),
        spec.target_y_mm - remaining_mm * np.sin(heading),
        spec.target_heading_deg,
    )


def render_frames(spec: SceneSpec) -> Iterator[tuple[np.ndarray, Box | None]]:
    """Yield (frame, car box or None) for every frame of the scene."""
    camera = spec.camera.camera()
    rng = np.random.default_rng(spec.seed)
    background = render_road(camera, spec.layout, rng)
    model = model_by_id(spec.model_id)
    colour = model.palette[spec.colour_index % len(model.palette)][1]
    lighting = Lighting.from_angles(spec.light_azimuth_deg, spec.light_elevation_deg, 0.45, 0.6)
    still: tuple[np.ndarray, Box | None] | None = None
    for frame in range(spec.frame_count):
        pose = car_pose_at(spec, frame)
        if pose is None:
            image, box = background, None
        elif frame >= spec.stop_frame and still is not None:
            image, box = still
        else:
            try:
                render = render_car(model, colour, pose, camera, background, lighting)
                image, box = render.image_bgr, render.box
            except ValueError:  # the car is not yet entirely in front of the camera
                image, box = background, None
            if frame >= spec.stop_frame:
                still = (image, box)
        noise = rng.normal(0.0, spec.noise_sigma, image.shape) if spec.noise_sigma > 0 else 0.0
        yield np.clip(image + noise, 0, 255).astype(np.uint8), box


def ground_truth(spec: SceneSpec, boxes: list[Box | None]) -> dict:
    """The scene's ground truth as a JSON-ready mapping."""
    camera = spec.camera.camera()
    model = model_by_id(spec.model_id)
    contacts_mm = spec.target_pose.car_to_world(tyre_contacts_car_mm(model))
    corners_mm = spec.target_pose.car_to_world(footprint_car_mm(model))
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
        "stop_frame": spec.stop_frame,
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
        "car": {
            "model_id": model.model_id,
            "make": model.make,
            "model": model.name,
            "length_mm": model.length_mm,
            "width_mm": model.width_mm,
            "height_mm": model.height_mm,
            "wheelbase_mm": model.wheelbase_mm,
            "pose": {"x_mm": spec.target_x_mm, "y_mm": spec.target_y_mm, "heading_deg": spec.target_heading_deg},
            "tyre_contacts_mm": contacts_mm[:, :2].tolist(),
            "tyre_contacts_px": camera.project(contacts_mm).tolist(),
            "tyre_order": ["front_left", "front_right", "rear_left", "rear_right"],
            "footprint_corners_mm": corners_mm[:, :2].tolist(),
            "footprint_corners_px": camera.project(corners_mm).tolist(),
            "footprint_order": ["front_left", "front_right", "rear_right", "rear_left"],
            "plates": {
                end: {"corners_mm": plate.corners_mm.tolist(), "corners_px": plate.corners_px.tolist(),
                      "centre_px": camera.project(plate.centre_mm[None])[0].tolist(), "faces_camera": plate.faces_camera}
                for end, plate in plates_seen(model, spec.target_pose, camera).items()
            },
            "plate_corner_order": "counter-clockwise seen from outside the car, from the lower corner on its right",
        },
        "boxes_xyxy_px": [None if box is None else list(box.to_inclusive()) for box in boxes],
        "box_convention": "0-based inclusive x1 y1 x2 y2 of the pixels the car covers at least half; null when absent",
    }


def write_scene(spec: SceneSpec, out_dir: Path) -> tuple[Path, Path]:
    """Render a scene to `out_dir/video.avi` and `out_dir/ground_truth.json`; return both paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    video_path, truth_path = out_dir / "video.avi", out_dir / "ground_truth.json"
    size = (spec.camera.width_px, spec.camera.height_px)
    writer = cv2.VideoWriter(str(video_path), cv2.VideoWriter_fourcc(*CODECS[spec.codec]), spec.fps, size)
    writer.set(cv2.VIDEOWRITER_PROP_QUALITY, MJPEG_QUALITY)
    if not writer.isOpened():
        raise RuntimeError(f"OpenCV cannot write {CODECS[spec.codec]} video to {video_path}")
    boxes = []
    try:
        for frame, box in render_frames(spec):
            writer.write(frame)
            boxes.append(box)
    finally:
        writer.release()
    truth_path.write_text(json.dumps(ground_truth(spec, boxes), indent=1))
    return video_path, truth_path
