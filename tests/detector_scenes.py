"""Rendered vehicle ROIs with exact ground truth for the key-footprint-point detectors: the Table 2 test site's
camera (conf/scene/table2_site.yaml) over its road, a catalog car at a Table 2 pose (across the road, side-on:
the wheel branch) or at a plate pose (along the road, front or rear towards the camera: the plate branch),
sensor noise like the scenes', and the ROI of the paper: the car's box enlarged by 10 %."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np

from vehloc.config import read_config
from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import CarPose, CarRender, Lighting, PlateTruth, render_car
from vehloc.synth.road import RoadLayout, render_road

TABLE2_POSES = ("table2_close_0", "table2_close_30", "table2_close_minus30",
                "table2_middle_0", "table2_middle_30", "table2_middle_minus30")
PLATE_POSES = {  # along the road, the front or the rear towards the camera, at about 4 m and 10 m
    "near_front": CarPose(300.0, 4000.0, -90.0),
    "near_rear": CarPose(-500.0, 4200.0, 90.0),
    "near_front_30": CarPose(800.0, 4500.0, -120.0),
    "far_front_20": CarPose(1200.0, 10000.0, -70.0),
    "far_rear_20": CarPose(-1500.0, 10500.0, 110.0),
    "far_rear_30": CarPose(-800.0, 9800.0, 60.0),
}
SMALL_PLATE_POSES = {  # along the road, 19-24 m away: plates 15-18 px wide, 5-6 px tall
    "small_front_22": CarPose(900.0, 20000.0, -80.0),
    "small_rear_24": CarPose(-1200.0, 22000.0, 100.0),
    "small_rear_30": CarPose(-600.0, 19000.0, 60.0),
    "small_front_26": CarPose(1500.0, 24000.0, -110.0),
}
SMALL_PLATE_QUARTER_POSES = {  # 15-17 m away, the rear and a side in view: a small plate and two wheels
    "small_rear_quarter_60": CarPose(1200.0, 17000.0, 60.0),
    "small_rear_quarter_120": CarPose(-800.0, 15000.0, 120.0),
}
OBLIQUE_POSES = {  # 45-50 deg off the road's axis, 5-6 m away: seen from above, the far wheel of the near side stands
    "oblique_rear_left": CarPose(-1500.0, 6000.0, 45.0),  # high in the silhouette, the near one low
    "oblique_rear_right": CarPose(1500.0, 6000.0, 135.0),
    "oblique_rear_verge": CarPose(-2000.0, 5000.0, 50.0),
}
END_ON_POSES = ("near_front", "near_rear")
SILVER, BLACK, WHITE = (9, 2), (1, 0), (1, 1)  # (model id, palette index): Honda Spirior silver, BMW 7 black, white
YELLOW_DARK_RIMS, RED_PICKUP, WHITE_SMALL = (6, 0), (12, 4), (11, 1)


@cache
def site() -> tuple[PinholeCamera, RoadLayout, Lighting, float]:
    """The Table 2 site's camera, road layout, light and sensor noise."""
    config = read_config("scene/table2_site.yaml")
    camera = config["camera"]
    pinhole = PinholeCamera.look_at(camera["position_mm"], camera["target_mm"], camera["focal_px"],
                                    camera["width_px"], camera["height_px"], camera["roll_deg"])
    lighting = Lighting.from_angles(config["light_azimuth_deg"], config["light_elevation_deg"], 0.45, 0.6)
    return pinhole, RoadLayout(**config["layout"]), lighting, float(config["noise_sigma"])


def table2_pose(name: str) -> CarPose:
    """The car's pose of a Table 2 scene config."""
    car = read_config(f"scene/{name}.yaml")["cars"][0]
    return CarPose(car["target_x_mm"], car["target_y_mm"], car["target_heading_deg"])


def pose_named(name: str) -> CarPose:
    return table2_pose(name) if name.startswith("table2") else (PLATE_POSES | SMALL_PLATE_POSES | SMALL_PLATE_QUARTER_POSES | OBLIQUE_POSES)[name]


@cache
def road(seed: int) -> np.ndarray:
    camera, layout, _, _ = site()
    return render_road(camera, layout, np.random.default_rng(seed))


@dataclass(frozen=True, eq=False)
class Case:
    """A rendered car and its ROI: the crop, its foreground mask and its top-left in the frame."""

    render: CarRender
    camera: PinholeCamera
    pose: CarPose
    roi_bgr: np.ndarray
    mask: np.ndarray
    offset_px: np.ndarray

    @property
    def camera_foot_mm(self) -> np.ndarray:
        return self.camera.centre_mm[:2]

    def near_contacts_px(self) -> np.ndarray:
        """The true tyre contacts (2, 2) px of the side turned to the camera (front then rear)."""
        contacts = self.render.tyre_contacts_mm[:, :2]
        left, right = contacts[[0, 2]], contacts[[1, 3]]
        foot = self.camera_foot_mm
        near = left if np.linalg.norm(left.mean(axis=0) - foot) < np.linalg.norm(right.mean(axis=0) - foot) else right
        return self.camera.road_to_image()(near)

    def footprint_edges_mm(self) -> dict[str, np.ndarray]:
        """The true footprint's edges (2, 2) road mm: left, right, front, rear."""
        c = self.render.footprint_corners_mm[:, :2]  # front-left, front-right, rear-right, rear-left
        return {"left": c[[0, 3]], "right": c[[1, 2]], "front": c[[0, 1]], "rear": c[[3, 2]]}

    def facing_plate(self) -> PlateTruth | None:
        """The plate turned to the camera, or None."""
        return next((plate for plate in self.render.plates.values() if plate.faces_camera), None)


def render_case(car: tuple[int, int], pose_name: str, degrade: str = "none", seed: int = 0) -> Case:
    """A catalog car (model id, palette index) at a named pose; `degrade` the mask by a pixel ("erode",
    "dilate") as a background model would."""
    camera, _, lighting, noise_sigma = site()
    model = model_by_id(car[0])
    pose = pose_named(pose_name)
    render = render_car(model, model.palette[car[1]][1], pose, camera, road(seed), lighting)
    rng = np.random.default_rng(seed + 1)
    frame = np.clip(render.image_bgr + rng.normal(0.0, noise_sigma, render.image_bgr.shape), 0, 255).astype(np.uint8)
    assert render.box is not None
    box = render.box.enlarged(0.1, camera.width_px, camera.height_px)
    mask = box.crop(render.mask).astype(np.uint8)
    if degrade != "none":
        mask = {"erode": cv2.erode, "dilate": cv2.dilate}[degrade](mask, np.ones((3, 3), np.uint8))
    return Case(render, camera, pose, box.crop(frame), mask.astype(bool), np.array([box.x0, box.y0], float))


def road_distance_mm(line_mm: np.ndarray, points_mm: np.ndarray) -> np.ndarray:
    """Signed distances (mm) of road points from a normalised road line (positive on the vehicle's side)."""
    return np.asarray(points_mm, dtype=float) @ line_mm[:2] + line_mm[2]


def heading_error_deg(length_heading_deg: float, heading_deg: float) -> float:
    """Difference of two axis directions, modulo 180 deg."""
    return abs((length_heading_deg - heading_deg + 90.0) % 180.0 - 90.0)
