"""Procedural car catalog and renderer: the embedded demo data (CompCars-format images, traffic scenes with exact
ground truth, flowing traffic with its speed truth). The names below are its API."""

from vehloc.api import lazy_api

__all__, __getattr__ = lazy_api(__name__, {
    "catalog": ["CarModel"],
    "demo_set": ["make_demo_set"],
    "render": ["CarPose", "Lighting", "render_car"],
    "road": ["RoadLayout", "render_road"],
    "scene": ["CameraSpec", "CarSpec", "SceneError", "SceneSpec", "render_frames", "write_scene"],
    "speed_truth": ["speed_ground_truth"],
    "traffic": ["TrafficLane", "TrafficSpec", "scene_from_config", "traffic_cars"],
})
