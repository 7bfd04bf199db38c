"""What localization needs of a camera's calibration (`CameraCalibration`), and reading it from the
`calibration.json` that `vehloc-calibrate` writes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vehloc.data.text import read_json
from vehloc.geometry.calibration import CalibrationError, camera_from_homography
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.projective import ProjectiveTransform


@dataclass(frozen=True)
class CameraCalibration:
    """What localization needs of a calibration: the road homography, the camera when it can be recovered
    from it, the image size it holds for, its reprojection error and the relative 1-sigma of its scale (0 for a
    surveyed site; an automatic calibration's from the vehicles that scaled it)."""

    road_to_image: ProjectiveTransform
    image_size_px: tuple[int, int]
    camera: PinholeCamera | None
    rms_reprojection_px: float
    source: str
    scale_sigma_fraction: float = 0.0

    @classmethod
    def from_homography(cls, homography: np.ndarray, image_size_px: tuple[int, int], rms_reprojection_px: float,
                        source: str, scale_sigma_fraction: float = 0.0) -> CameraCalibration:
        road_to_image = ProjectiveTransform.road_to_image(homography, *image_size_px)
        try:
            camera = camera_from_homography(road_to_image, *image_size_px).camera
        except CalibrationError:
            camera = None
        return cls(road_to_image, tuple(image_size_px), camera, float(rms_reprojection_px), source,
                   float(scale_sigma_fraction))

    def check_image_size(self, width_px: int, height_px: int, what: str) -> None:
        """CalibrationError when `what` (a video or image) is not of the calibrated size."""
        if (width_px, height_px) != self.image_size_px:
            raise CalibrationError(
                f"{self.source} calibrates {self.image_size_px[0]}x{self.image_size_px[1]} px images, "
                f"{what} is {width_px}x{height_px} px"
            )


def check_road_homography(homography: np.ndarray, image_size_px: tuple[int, int], source: str) -> None:
    """CalibrationError naming `source` unless the road -> image homography can be a camera's view of the road: of
    rank 3 (not the road squashed onto a line), its horizon (the image of the road's line at infinity) clear of the
    image's bottom row, where the road nearest the camera is seen."""
    scaled = homography / np.abs(homography).max()
    rank = int(np.linalg.matrix_rank(scaled, tol=1e-9))
    if rank < 3:
        raise CalibrationError(f"{source}: the homography is singular (rank {rank}): it maps the road onto a line or point")
    horizon = np.linalg.inv(scaled).T @ np.array([0.0, 0.0, 1.0])
    width_px, height_px = image_size_px
    bottom_row = np.array([[0.0, height_px - 1.0, 1.0], [width_px - 1.0, height_px - 1.0, 1.0]])
    sides = bottom_row @ horizon
    if sides[0] * sides[1] <= 0.0:
        raise CalibrationError(f"{source}: the road's horizon crosses the image's bottom row: the homography does not "
                               "show a road below its horizon")


def read_calibration(path: str | Path) -> CameraCalibration:
    """The calibration written by `vehloc-calibrate` (`calibration.json`); CalibrationError naming the file
    when it is missing or not one."""
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"{path}: calibration file does not exist")
    content = read_json(path, CalibrationError)
    try:
        homography = np.array(content["homography_world_mm_to_image_px"], dtype=float)
        size = tuple(int(v) for v in content["image_size_px"])
        rms = float(content["rms_reprojection_px"])
        scale_sigma = float(content.get("scale_sigma_fraction", 0.0))
    except (KeyError, TypeError, ValueError) as err:
        raise CalibrationError(f"{path}: not a calibration.json of vehloc-calibrate ({type(err).__name__}: {err})") from None
    if homography.shape != (3, 3) or not np.all(np.isfinite(homography)) or len(size) != 2 or min(size) <= 0:
        raise CalibrationError(f"{path}: needs a 3x3 homography of finite numbers and a positive image size")
    if not (np.isfinite(scale_sigma) and scale_sigma >= 0.0):
        raise CalibrationError(f"{path}: scale_sigma_fraction must be a finite number >= 0, got {scale_sigma}")
    if not (np.isfinite(rms) and rms >= 0.0):
        raise CalibrationError(f"{path}: rms_reprojection_px must be a finite number >= 0, got {rms}")
    check_road_homography(homography, size, str(path))
    try:
        return CameraCalibration.from_homography(homography, size, rms, str(path), scale_sigma)
    except ValueError as err:
        raise CalibrationError(f"{path}: {err}") from None
