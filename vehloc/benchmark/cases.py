"""Seeded benchmark cases: one stopped catalog car per scene, drawn over every model, its palette's colours,
headings all round, distances and lateral positions across the lanes, the benchmark's cameras, the sun's
direction and plate presence. The same seed always gives the same case; a draw whose car would not stand
wholly inside the image is redrawn from the same seed's generator."""

from __future__ import annotations

import colorsys
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from vehloc.config import SettingError, build_params, check_range
from vehloc.synth.body import build_car_mesh
from vehloc.synth.catalog import CATALOG, RGB, model_by_id
from vehloc.synth.render import CarPose
from vehloc.synth.road import RoadLayout
from vehloc.synth.scene import CameraSpec, CarSpec, SceneSpec

COLOUR_GROUPS = ("white", "black", "grey", "saturated")


@dataclass(frozen=True)
class DrawParams:
    """The ranges the cases are drawn from (`draw:` of `conf/localization_benchmark.yaml`)."""

    distance_mm: tuple[float, float]
    light_azimuth_deg: tuple[float, float]
    light_elevation_deg: tuple[float, float]
    plate_probability: float
    approach_mm: float
    drive_frames: int
    stopped_frames: int
    margin_px: float
    max_tries: int

    def __post_init__(self) -> None:
        check_range("distance_mm", self.distance_mm[0], 0.0, self.distance_mm[1], low_open=True)
        check_range("light_elevation_deg", self.light_elevation_deg[0], 0.0, self.light_elevation_deg[1], low_open=True)
        check_range("light_elevation_deg", self.light_elevation_deg[1], self.light_elevation_deg[0], 90.0)
        check_range("plate_probability", self.plate_probability, 0.0, 1.0)
        check_range("approach_mm", self.approach_mm, 0.0, low_open=True)
        check_range("drive_frames", self.drive_frames, 1)
        check_range("stopped_frames", self.stopped_frames, 1)
        check_range("margin_px", self.margin_px, 0.0)
        check_range("max_tries", self.max_tries, 1)


@dataclass(frozen=True)
class BenchmarkCase:
    """One drawn case: the seed, the camera's name, the car (model, palette entry, pose, plates) and the light."""

    seed: int
    camera_name: str
    model_id: int
    colour_index: int
    colour: str
    colour_group: str
    x_mm: float
    y_mm: float
    heading_deg: float
    distance_mm: float
    light_azimuth_deg: float
    light_elevation_deg: float
    plates: bool

    @property
    def pose(self) -> CarPose:
        return CarPose(self.x_mm, self.y_mm, self.heading_deg)

    def scene_spec(self, site: Mapping[str, Any], camera: CameraSpec, draw: DrawParams) -> SceneSpec:
        """The case as a scene on the road, empty frames, sensor and codec of `site` (a scene config without
        cars): `camera`, the case's light, and its car driving in and stopping."""
        car = CarSpec(self.model_id, self.colour_index, self.x_mm, self.y_mm, self.heading_deg, draw.approach_mm,
                      True, 0, self.plates)
        return SceneSpec.from_dict({
            **site, "name": f"benchmark_{self.seed}", "camera": asdict(camera), "cars": [asdict(car)],
            "drive_frames": draw.drive_frames, "stopped_frames": draw.stopped_frames,
            "light_azimuth_deg": self.light_azimuth_deg, "light_elevation_deg": self.light_elevation_deg,
            "seed": self.seed,
        })


def colour_group(rgb: RGB) -> str:
    """`white`, `black`, `grey` or `saturated`: a paint's group by its HSV saturation and value."""
    _, saturation, value = colorsys.rgb_to_hsv(*(c / 255.0 for c in rgb))
    if saturation >= 0.35 and value >= 0.2:
        return "saturated"
    if value < 0.25:
        return "black"
    return "white" if value >= 0.85 and saturation < 0.15 else "grey"


def cameras_from_config(values: Mapping[str, Any]) -> dict[str, CameraSpec]:
    """The benchmark's cameras by name (`cameras:` of the config), each checked."""
    if not isinstance(values, Mapping) or not values:
        raise SettingError("cameras", "must name at least one camera")
    return {str(name): build_params(CameraSpec, spec, f"cameras.{name}") for name, spec in values.items()}


def in_view(camera: CameraSpec, model_id: int, pose: CarPose, margin_px: float) -> bool:
    """Whether every vertex of the car's body at `pose` lies in front of the camera and at least `margin_px`
    inside the image."""
    model = model_by_id(model_id)
    pinhole = camera.camera()
    vertices = pose.car_to_world(build_car_mesh(model).vertices_mm)
    if np.any(pinhole.to_camera(vertices)[:, 2] <= 100.0):
        return False
    pixels = pinhole.project(vertices)
    return bool(np.all(np.isfinite(pixels)) and pixels[:, 0].min() >= margin_px and pixels[:, 1].min() >= margin_px
                and pixels[:, 0].max() <= camera.width_px - 1 - margin_px
                and pixels[:, 1].max() <= camera.height_px - 1 - margin_px)


def draw_case(seed: int, cameras: Mapping[str, CameraSpec], layout: RoadLayout, draw: DrawParams) -> BenchmarkCase:
    """The case of `seed`: the model, colour, camera, plate presence and light first, then poses (the car's
    centre on the road, `distance_mm` from the camera's foot) until one stands wholly in the image."""
    rng = np.random.default_rng([seed, 28])
    model = CATALOG[int(rng.integers(len(CATALOG)))]
    colour_index = int(rng.integers(len(model.palette)))
    colour, rgb = model.palette[colour_index]
    names = sorted(cameras)
    camera_name = names[int(rng.integers(len(names)))]
    camera = cameras[camera_name]
    plates = bool(rng.random() < draw.plate_probability)
    azimuth = float(rng.uniform(*draw.light_azimuth_deg))
    elevation = float(rng.uniform(*draw.light_elevation_deg))
    half_road_mm = layout.road_width_mm / 2
    foot = np.asarray(camera.position_mm[:2], dtype=float)
    for _ in range(draw.max_tries):
        x_mm = float(rng.uniform(-half_road_mm + model.width_mm / 2, half_road_mm - model.width_mm / 2))
        distance_mm = float(rng.uniform(*draw.distance_mm))
        heading_deg = float(rng.uniform(0.0, 360.0))
        across_mm = x_mm - foot[0]
        if abs(across_mm) >= distance_mm:
            continue
        y_mm = float(foot[1] + np.sqrt(distance_mm**2 - across_mm**2))
        pose = CarPose(x_mm, y_mm, heading_deg)
        if in_view(camera, model.model_id, pose, draw.margin_px):
            return BenchmarkCase(seed, camera_name, model.model_id, colour_index, colour, colour_group(rgb), x_mm,
                                 y_mm, heading_deg, distance_mm, azimuth, elevation, plates)
    raise SettingError("draw", f"seed {seed}: no pose of {model.name} in view of camera {camera_name} "
                               f"after {draw.max_tries} tries")
