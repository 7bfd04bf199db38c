"""Calibrating a camera site from one image: markers detected, homography estimated and refined, camera
recovered; a typed result for the CLI to write and the localization to use."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vehloc.atomic import atomic_paths, encode_image

from vehloc.geometry.calibration import (
    Calibration,
    CalibrationError,
    CalibrationParams,
    CameraFromHomography,
    calibrate,
    calibrate_from_guess,
    camera_from_homography,
    image_size_of,
)
from vehloc.geometry.camera_calibration import CameraCalibration
from vehloc.geometry.markers import DetectedMarker, MarkerDetectionParams, detect_markers
from vehloc.geometry.pipeline.overlay import draw_calibration
from vehloc.geometry.site import Site, SiteError

CALIBRATION_MODES = ("detect", "guess")


@dataclass(frozen=True)
class SiteCalibration:
    """The calibration of a site from one image: detected markers, the road homography, the camera."""

    site_name: str
    mode: str
    image_size_px: tuple[int, int]
    markers: tuple[DetectedMarker, ...]
    calibration: Calibration
    camera: CameraFromHomography | None

    def camera_calibration(self, source: str) -> CameraCalibration:
        """The calibration as localization uses it."""
        return CameraCalibration.from_homography(
            self.calibration.homography, self.image_size_px, self.calibration.rms_reprojection_px, source
        )

    def summary(self) -> dict[str, object]:
        """JSON-ready figures: homography, inliers, reprojection errors, and the camera when recoverable."""
        summary: dict[str, object] = {
            "site": self.site_name, "mode": self.mode, "image_size_px": list(self.image_size_px),
            "detected_markers": len(self.markers),
        }
        summary |= self.calibration.summary()
        if self.camera is None:
            summary["camera"] = "not recoverable from this homography"
        else:
            summary |= {
                "focal_px": self.camera.focal_px,
                "camera_height_mm": self.camera.height_mm,
                "camera_tilt_deg": self.camera.tilt_deg,
                "camera_centre_mm": self.camera.camera.centre_mm.tolist(),
            }
        return summary


def check_mode(mode: str) -> None:
    if mode not in CALIBRATION_MODES:
        raise CalibrationError(f"mode must be 'detect' or 'guess', got {mode!r}")


def check_image_size(site: Site, image_bgr: np.ndarray, image_name: str = "the image") -> None:
    """SiteError when the site was surveyed for an image of another size."""
    size = image_size_of(image_bgr)
    if site.image_size_px is not None and tuple(site.image_size_px) != size:
        raise SiteError(
            f"{site.label}: image_size_px is {site.image_size_px[0]}x{site.image_size_px[1]}, "
            f"{image_name} is {size[0]}x{size[1]} px"
        )


def calibrate_site(
    site: Site,
    image_bgr: np.ndarray,
    mode: str = "detect",
    detection: MarkerDetectionParams | None = None,
    params: CalibrationParams | None = None,
    image_name: str = "the image",
) -> SiteCalibration:
    """Calibrate the camera of `site` from one image (`mode`: `detect` matches detected marker blobs to the
    surveyed ones; `guess` refines the site's clicked points on the predicted marker edges); SiteError when the
    site's image_size_px is not the image's."""
    check_mode(mode)
    check_image_size(site, image_bgr, image_name)
    markers = tuple(detect_markers(image_bgr, detection))
    if mode == "detect":
        calibration = calibrate(markers, site, params, image_bgr)
    else:
        calibration = calibrate_from_guess(image_bgr, site, params)
    width_px, height_px = image_size_of(image_bgr)
    try:
        camera = camera_from_homography(calibration.transform, width_px, height_px)
    except CalibrationError:
        camera = None
    return SiteCalibration(site.name, mode, (width_px, height_px), markers, calibration, camera)


def write_calibration_files(
    result: SiteCalibration, image_bgr: np.ndarray, out_dir: Path, grid_step_mm: float, sources: dict[str, str]
) -> dict[str, object]:
    """`image.png` (the image calibrated on), `calibration.json` (`sources`, e.g. the site and image paths, and
    the summary) and `overlay.png` (detections and the world grid projected back), written together: each to a
    temporary file first, and all three renamed into place only when every one is complete, so that an
    interrupt or a failure leaves an earlier calibration there whole."""
    summary = dict(sources) | result.summary()
    contents = {
        "image.png": encode_image("image.png", image_bgr),
        "calibration.json": (json.dumps(summary, indent=2) + "\n").encode("utf-8"),
        "overlay.png": encode_image(
            "overlay.png", draw_calibration(image_bgr, list(result.markers), result.calibration, grid_step_mm)),
    }
    with atomic_paths([out_dir / name for name in contents]) as temporaries:
        for temporary, data in zip(temporaries, contents.values()):
            temporary.write_bytes(data)
    return summary
