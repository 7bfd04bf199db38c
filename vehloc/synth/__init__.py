"""Procedural car catalog and renderer: the embedded demo data (CompCars-format images, traffic scenes with exact
ground truth). The names below are its API."""

from vehloc.synth.catalog import CarModel
from vehloc.synth.demo_set import make_demo_set
from vehloc.synth.render import CarPose, Lighting, render_car
from vehloc.synth.road import RoadLayout, render_road
from vehloc.synth.scene import CameraSpec, CarSpec, SceneError, SceneSpec, render_frames, write_scene

__all__ = [
    "CameraSpec", "CarModel", "CarPose", "CarSpec", "Lighting", "RoadLayout", "SceneError", "SceneSpec",
    "make_demo_set", "render_car", "render_frames", "render_road", "write_scene",
]
