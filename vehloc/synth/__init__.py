"""Procedural car catalog and renderer: the embedded demo data (CompCars-format images, traffic scenes with exact
ground truth). The names below are its API."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "catalog": ["CarModel"],
    "demo_set": ["make_demo_set"],
    "render": ["CarPose", "Lighting", "render_car"],
    "road": ["RoadLayout", "render_road"],
    "scene": ["CameraSpec", "CarSpec", "SceneError", "SceneSpec", "render_frames", "write_scene"],
})
