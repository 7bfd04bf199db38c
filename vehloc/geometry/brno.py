"""The field's speed benchmark's camera model (BrnoCompSpeed, Sochor et al.; its `code/loading.py`): a camera given
by the vanishing points of the road's two directions (`vp1` along the traffic, `vp2` across it) and the principal
point, the focal length and the road plane recovered from them (the plane 10 units from the origin), and a `scale`
that turns that plane's units into metres. Re-implemented here to write results its scorer reads and to read them
back the way it does."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.projective import ProjectiveTransform

ROAD_PLANE_OFFSET = 10.0
"""The road plane's offset in the scorer's unscaled world (`computeCameraCalibration`)."""
ALONG_ROAD = np.array([0.0, 1.0, 0.0])
ACROSS_ROAD = np.array([1.0, 0.0, 0.0])
"""The road's directions in vehloc's world frame (Y along the road, X across it)."""


@dataclass(frozen=True)
class BrnoCalibration:
    """The benchmark's `camera_calibration` block: the two vanishing points and the principal point (px), and the
    scale (metres per unit of its road plane)."""

    vp1_px: tuple[float, float]
    vp2_px: tuple[float, float]
    pp_px: tuple[float, float]
    scale: float

    def to_json(self) -> dict[str, object]:
        return {"vp1": list(self.vp1_px), "vp2": list(self.vp2_px), "pp": list(self.pp_px), "scale": self.scale}


def focal_and_road_plane(vp1_px: np.ndarray, vp2_px: np.ndarray, pp_px: np.ndarray) -> tuple[float, np.ndarray]:
    """The focal length (px) and the road plane (a, b, c, d) of the scorer's `computeCameraCalibration`; ValueError
    when the vanishing points are not those of two perpendicular directions seen by a camera with that principal
    point."""
    vp1, vp2, pp = (np.asarray(v, dtype=float)[:2] for v in (vp1_px, vp2_px, pp_px))
    focal_squared = -float(np.dot(vp1 - pp, vp2 - pp))
    if not focal_squared > 0.0:
        raise ValueError("the vanishing points do not belong to perpendicular road directions (no real focal length)")
    focal = float(np.sqrt(focal_squared))
    vp1_w, vp2_w, pp_w = np.append(vp1, focal), np.append(vp2, focal), np.append(pp, 0.0)
    vp3_w = np.cross(vp1_w - pp_w, vp2_w - pp_w)
    vp3 = vp3_w[:2] / vp3_w[2] * focal + pp_w[:2]
    direction = np.append(vp3, focal) - pp_w
    return focal, np.append(direction / np.linalg.norm(direction), ROAD_PLANE_OFFSET)


def road_plane_points(points_px: np.ndarray, focal_px: float, road_plane: np.ndarray, pp_px: np.ndarray) -> np.ndarray:
    """Image points (N, 2) on the scorer's road plane, (N, 3) in its unscaled world
    (`getWorldCoordinagesOnRoadPlane`)."""
    points = np.asarray(points_px, dtype=float).reshape(-1, 2)
    pp_w = np.append(np.asarray(pp_px, dtype=float)[:2], 0.0)
    directions = np.column_stack([points, np.full(len(points), focal_px)]) - pp_w
    t = -float(road_plane @ np.append(pp_w, 1.0)) / (directions @ road_plane[:3])
    return pp_w + t[:, None] * directions


def project_to_metres(points_px: np.ndarray, calibration: BrnoCalibration) -> np.ndarray:
    """Image points (N, 2) on the road, in the scorer's world scaled to metres (N, 3)."""
    focal, plane = focal_and_road_plane(np.array(calibration.vp1_px), np.array(calibration.vp2_px),
                                        np.array(calibration.pp_px))
    return calibration.scale * road_plane_points(points_px, focal, plane, np.array(calibration.pp_px))


def vanishing_point_px(camera: PinholeCamera, direction: np.ndarray) -> np.ndarray:
    """Where a world direction's parallel lines meet in the image (px); infinite when it is parallel to the image."""
    homogeneous = camera.K @ camera.R @ np.asarray(direction, dtype=float)
    if abs(homogeneous[2]) < 1e-12 * np.linalg.norm(homogeneous):
        return np.full(2, np.inf)
    return homogeneous[:2] / homogeneous[2]


def brno_calibration(camera: PinholeCamera, road_to_image: ProjectiveTransform, road_points_mm: np.ndarray) -> BrnoCalibration:
    """The benchmark's calibration of a calibrated camera: the vanishing points of the road's directions, the
    principal point, and the scale fitted (least squares) so that the distances between `road_points_mm` (N, 2),
    points of the road where vehicles are measured, come out in metres through the scorer's projection of their
    pixels under `road_to_image`. ValueError when a vanishing point is at infinity (the benchmark's model cannot
    hold such a camera: the road's direction parallel to the image)."""
    vp1, vp2 = vanishing_point_px(camera, ALONG_ROAD), vanishing_point_px(camera, ACROSS_ROAD)
    if not (np.all(np.isfinite(vp1)) and np.all(np.isfinite(vp2))):
        raise ValueError("a road direction is parallel to the image: its vanishing point is at infinity")
    pp = camera.K[:2, 2]
    focal, plane = focal_and_road_plane(vp1, vp2, pp)
    points_mm = np.asarray(road_points_mm, dtype=float).reshape(-1, 2)
    unscaled = road_plane_points(road_to_image(points_mm), focal, plane, pp)
    first, second = np.triu_indices(len(points_mm), k=1)
    true_m = np.linalg.norm(points_mm[first] - points_mm[second], axis=1) / 1000.0
    measured = np.linalg.norm(unscaled[first] - unscaled[second], axis=1)
    scale = float(measured @ true_m / (measured @ measured))
    return BrnoCalibration(tuple(float(v) for v in vp1), tuple(float(v) for v in vp2), tuple(float(v) for v in pp), scale)
