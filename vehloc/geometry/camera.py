"""Pinhole camera in the paper's world frame, and its road-plane homography.

World frame (millimetres): origin in the middle of the road, X across the road to the right, Y along
the road, Z up; the road is the plane Z = 0. Camera frame: OpenCV's (x right, y down, z forward along
the optical axis). A world point P maps to the camera frame as ``R @ P + t`` and to pixels through
``K``; pixel coordinates are continuous with (0, 0) at the centre of the top-left pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.geometry.projective import ProjectiveTransform


def _rotation_from_angles(yaw_deg: float, pitch_deg: float, roll_deg: float) -> np.ndarray:
    """World-to-camera rotation for the angle conventions of `PinholeCamera.from_pose`."""
    yaw, pitch, roll = np.radians([yaw_deg, pitch_deg, roll_deg])
    forward = np.array([np.sin(yaw) * np.cos(pitch), np.cos(yaw) * np.cos(pitch), -np.sin(pitch)])
    right = np.array([np.cos(yaw), -np.sin(yaw), 0.0])
    down = np.cross(forward, right)
    cos_r, sin_r = np.cos(roll), np.sin(roll)
    rolled_right = cos_r * right + sin_r * down
    rolled_down = -sin_r * right + cos_r * down
    return np.stack([rolled_right, rolled_down, forward])


NEAR_PLANE_MM = 50.0


def clip_to_near_plane(points_cam_mm: np.ndarray, near_mm: float = NEAR_PLANE_MM) -> np.ndarray:
    """Clip a camera-frame polygon (N, 3) to z >= near_mm (Sutherland-Hodgman); may return no points."""
    if np.all(points_cam_mm[:, 2] >= near_mm):
        return np.array(points_cam_mm, dtype=float).reshape(-1, 3)
    out = []
    n = len(points_cam_mm)
    for i in range(n):
        a, b = points_cam_mm[i], points_cam_mm[(i + 1) % n]
        a_in, b_in = a[2] >= near_mm, b[2] >= near_mm
        if a_in:
            out.append(a)
        if a_in != b_in:
            out.append(a + (b - a) * (near_mm - a[2]) / (b[2] - a[2]))
    return np.array(out, dtype=float).reshape(-1, 3)


def _as_points(points: np.ndarray, dim: int) -> np.ndarray:
    array = np.asarray(points, dtype=float)
    if array.ndim == 1:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != dim:
        raise ValueError(f"expected points of shape (N, {dim}), got {np.shape(points)}")
    return array


@dataclass(frozen=True, eq=False)
class PinholeCamera:
    """A pinhole camera: intrinsics ``K``, world-to-camera rotation ``R`` and translation ``t`` (mm)."""

    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    width_px: int
    height_px: int

    def __post_init__(self) -> None:
        for name, shape in (("K", (3, 3)), ("R", (3, 3)), ("t", (3,))):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != shape:
                raise ValueError(f"PinholeCamera.{name} must have shape {shape}, got {value.shape}")
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @staticmethod
    def intrinsics(
        focal_px: float, width_px: int, height_px: int, principal_px: tuple[float, float] | None = None
    ) -> np.ndarray:
        """K with square pixels; the principal point defaults to the image centre."""
        cx, cy = principal_px if principal_px is not None else ((width_px - 1) / 2, (height_px - 1) / 2)
        return np.array([[focal_px, 0.0, cx], [0.0, focal_px, cy], [0.0, 0.0, 1.0]])

    @classmethod
    def from_pose(
        cls,
        position_mm: np.ndarray,
        yaw_deg: float,
        pitch_deg: float,
        roll_deg: float,
        focal_px: float,
        width_px: int,
        height_px: int,
        principal_px: tuple[float, float] | None = None,
    ) -> PinholeCamera:
        """A camera at ``position_mm`` from its orientation angles.

        ``yaw_deg``: heading of the optical axis seen from above, 0 along +Y, positive towards +X
        (clockwise seen from above, like a compass with +Y as north). ``pitch_deg``: downward tilt of
        the optical axis below the horizontal, positive looking down (90 looks straight down, image up
        then along the yaw heading). ``roll_deg``: rotation of the image about the optical axis,
        positive turning the camera's x axis towards its y axis (scene appears rotated
        counter-clockwise in the image).
        """
        R = _rotation_from_angles(yaw_deg, pitch_deg, roll_deg)
        position = np.asarray(position_mm, dtype=float).reshape(3)
        K = cls.intrinsics(focal_px, width_px, height_px, principal_px)
        return cls(K=K, R=R, t=-R @ position, width_px=int(width_px), height_px=int(height_px))

    @classmethod
    def look_at(
        cls,
        position_mm: np.ndarray,
        target_mm: np.ndarray,
        focal_px: float,
        width_px: int,
        height_px: int,
        roll_deg: float = 0.0,
        principal_px: tuple[float, float] | None = None,
    ) -> PinholeCamera:
        """A camera at ``position_mm`` whose optical axis passes through ``target_mm``.

        The image x axis stays horizontal (before ``roll_deg``, as in `from_pose`); looking straight
        down, image up is +Y.
        """
        position = np.asarray(position_mm, dtype=float).reshape(3)
        direction = np.asarray(target_mm, dtype=float).reshape(3) - position
        norm = np.linalg.norm(direction)
        if norm == 0:
            raise ValueError("look_at: target coincides with the camera position")
        dx, dy, dz = direction / norm
        horizontal = np.hypot(dx, dy)
        yaw_deg = float(np.degrees(np.arctan2(dx, dy))) if horizontal > 1e-12 else 0.0
        pitch_deg = float(np.degrees(np.arctan2(-dz, horizontal)))
        return cls.from_pose(
            position, yaw_deg, pitch_deg, roll_deg, focal_px, width_px, height_px, principal_px
        )

    @property
    def centre_mm(self) -> np.ndarray:
        """Camera centre in world coordinates (mm)."""
        return -self.R.T @ self.t

    @property
    def focal_px(self) -> float:
        return float(self.K[0, 0])

    def to_camera(self, points_mm: np.ndarray) -> np.ndarray:
        """World points (N, 3) mm -> camera-frame points (N, 3) mm."""
        return _as_points(points_mm, 3) @ self.R.T + self.t

    def project_camera(self, points_cam_mm: np.ndarray) -> np.ndarray:
        """Camera-frame points (N, 3) -> pixels (N, 2); points with z <= 0 give NaN."""
        points = _as_points(points_cam_mm, 3)
        homogeneous = points @ self.K.T
        z = homogeneous[:, 2:3]
        with np.errstate(divide="ignore", invalid="ignore"):
            pixels = homogeneous[:, :2] / z
        pixels[(z <= 0)[:, 0]] = np.nan
        return pixels

    def project(self, points_mm: np.ndarray) -> np.ndarray:
        """World points (N, 3) mm -> pixels (N, 2); points at or behind the camera plane give NaN."""
        return self.project_camera(self.to_camera(points_mm))

    def project_polygon(self, polygon_mm: np.ndarray, near_mm: float = NEAR_PLANE_MM) -> np.ndarray:
        """World polygon (N, 3) mm -> its image polygon (M, 2) px, clipped to the near plane (M may be 0)."""
        visible = clip_to_near_plane(self.to_camera(polygon_mm), near_mm)
        return self.project_camera(visible) if len(visible) else np.zeros((0, 2))

    def road_to_image(self) -> ProjectiveTransform:
        """The road-plane homography H = K [r1 r2 t]: road points (X, Y) mm -> pixels; its ``w`` is the
        depth in front of the camera, so points behind it are reported, not imaged."""
        return ProjectiveTransform(self.K @ np.column_stack([self.R[:, 0], self.R[:, 1], self.t]), front_sign=1.0)

    def image_to_road(self, points_px: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) -> road-plane points (N, 2) mm, intersecting each pixel's ray with Z = 0 (NaN for
        pixels at or above the horizon)."""
        return self.road_to_image().inverse(_as_points(points_px, 2))
