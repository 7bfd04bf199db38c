"""Parametrisations of the road homography for refinement: free (8 parameters) or a pinhole camera
with square pixels and a known principal point (7: focal length, rotation, translation)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.projective import ProjectiveTransform


class FreeHomography:
    """H with h33 = 1: any plane-to-image projective map."""

    def to_homography(self, params: np.ndarray) -> np.ndarray:
        return np.append(params, 1.0).reshape(3, 3)

    def from_homography(self, road_to_image: ProjectiveTransform) -> np.ndarray:
        return road_to_image.normalised_matrix.ravel()[:8]

    def front_sign(self, road_to_image: ProjectiveTransform) -> float:
        """The visible side's sign of w once H is scaled to h33 = 1 (h33 never crosses 0 in refinement)."""
        return road_to_image.front_sign * float(np.sign(road_to_image.matrix[2, 2]))


@dataclass(frozen=True)
class PinholeHomography:
    """H = K(f) [r1 r2 t]: parameters log(f), Rodrigues rotation (3), translation in mm (3)."""

    width_px: int
    height_px: int

    def intrinsics(self, focal_px: float) -> np.ndarray:
        return PinholeCamera.intrinsics(focal_px, self.width_px, self.height_px)

    def to_homography(self, params: np.ndarray) -> np.ndarray:
        rotation, _ = cv2.Rodrigues(np.asarray(params[1:4], dtype=float))
        return self.intrinsics(float(np.exp(params[0]))) @ np.column_stack([rotation[:, 0], rotation[:, 1], params[4:7]])

    def camera(self, params: np.ndarray) -> PinholeCamera:
        rotation, _ = cv2.Rodrigues(np.asarray(params[1:4], dtype=float))
        return PinholeCamera(self.intrinsics(float(np.exp(params[0]))), rotation, np.asarray(params[4:7]), self.width_px, self.height_px)

    def from_homography(self, road_to_image: ProjectiveTransform) -> np.ndarray:
        """The camera closest to H: its image of a grid of road points in view matches H's."""
        grid_px = np.stack(
            np.meshgrid(np.linspace(0.1, 0.9, 5) * self.width_px, np.linspace(0.55, 0.95, 5) * self.height_px), -1
        ).reshape(-1, 2)
        world = road_to_image.inverse.map(grid_px)
        return self.fit_points(world.points[world.visible], grid_px[world.visible])

    def front_sign(self, road_to_image: ProjectiveTransform) -> float:
        """K [r1 r2 t] has the depth in front of the camera as its w: positive on the visible side."""
        return 1.0

    def fit_points(self, world_mm: np.ndarray, image_px: np.ndarray) -> np.ndarray:
        """Least-squares camera for >= 4 road-image correspondences, started from the best of a
        sweep of focal lengths (planar pose by IPPE at each)."""
        from scipy.optimize import least_squares  # scipy on first use: a refused CLI answers sooner
        object_points = np.column_stack([world_mm, np.zeros(len(world_mm))]).astype(np.float64)
        image_points = np.asarray(image_px, dtype=np.float64)
        best: tuple[float, np.ndarray] | None = None
        for focal_px in np.geomspace(0.3, 8.0, 40) * self.width_px:
            ok, rvec, tvec = cv2.solvePnP(object_points, image_points, self.intrinsics(focal_px), None, flags=cv2.SOLVEPNP_IPPE)
            if not ok:
                continue
            params = np.concatenate([[np.log(focal_px)], rvec.ravel(), tvec.ravel()])
            error = float(np.sum(self._reprojection(params, world_mm, image_points) ** 2))  # NaN: points behind
            if np.isfinite(error) and (best is None or error < best[0]):
                best = (error, params)
        if best is None:
            raise ValueError("no camera pose fits these points")
        result = least_squares(lambda p: self._reprojection(p, world_mm, image_points), best[1], x_scale="jac")
        return result.x

    def _reprojection(self, params: np.ndarray, world_mm: np.ndarray, image_px: np.ndarray) -> np.ndarray:
        return (ProjectiveTransform(self.to_homography(params))(world_mm) - image_px).ravel()
