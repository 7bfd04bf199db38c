"""`vehloc-calibrate site=... image=...`: calibrate a camera, write calibration.json and overlay.png."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from vehloc.errors import exit_on_error
from vehloc.geometry.calibration import (
    CalibrationError,
    CalibrationParams,
    calibrate,
    calibrate_from_guess,
    camera_from_homography,
)
from vehloc.geometry.markers import MarkerDetectionParams, detect_markers
from vehloc.geometry.overlay import draw_calibration
from vehloc.geometry.site import read_site
from vehloc.geometry.video import median_background, read_still

CONF_DIR = str(Path(__file__).resolve().parents[2] / "conf")


def run_calibration(cfg: DictConfig, out_dir: Path) -> dict[str, object]:
    """Calibrate from the configured site and image; write the results into `out_dir`."""
    site = read_site(cfg.site)
    if cfg.background_frames > 0:
        image = median_background(cfg.image, cfg.background_frames)
    else:
        image = read_still(cfg.image, cfg.frame_index)
    markers = detect_markers(image, MarkerDetectionParams(**cfg.detection))
    params = CalibrationParams(**cfg.calibration)
    if cfg.mode == "detect":
        calibration = calibrate(markers, site, params, image)
    elif cfg.mode == "guess":
        calibration = calibrate_from_guess(image, site, params)
    else:
        raise CalibrationError(f"mode must be 'detect' or 'guess', got {cfg.mode!r}")
    height_px, width_px = image.shape[:2]
    summary = {"site": str(cfg.site), "image": str(cfg.image), "mode": cfg.mode, "detected_markers": len(markers)}
    summary |= calibration.summary()
    try:
        camera = camera_from_homography(calibration.transform, width_px, height_px)
        summary |= {
            "focal_px": camera.focal_px,
            "camera_height_mm": camera.height_mm,
            "camera_tilt_deg": camera.tilt_deg,
            "camera_centre_mm": camera.camera.centre_mm.tolist(),
        }
    except CalibrationError:
        summary["camera"] = "not recoverable from this homography"
    out_dir.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(out_dir / "image.png"), image)
    (out_dir / "calibration.json").write_text(json.dumps(summary, indent=2))
    cv2.imwrite(str(out_dir / "overlay.png"), draw_calibration(image, markers, calibration, cfg.grid_step_mm))
    return summary


@hydra.main(version_base="1.3", config_path=CONF_DIR, config_name="calibrate")
@exit_on_error("vehloc-calibrate")
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    summary = run_calibration(cfg, out_dir)
    kind = "clicked points" if cfg.mode == "guess" else "corners"
    edge = summary["median_edge_px"]
    print(
        f"{summary['inliers']}/{summary['matched_corners']} {kind} inliers, RMS {summary['rms_reprojection_px']:.2f} px "
        f"/ {summary['rms_road_error_mm']:.0f} mm on the road"
        + (f", median edge distance {edge:.2f} px" if edge is not None else "")
        + f"; wrote {out_dir / 'calibration.json'} and overlay.png"
    )


if __name__ == "__main__":
    main()
