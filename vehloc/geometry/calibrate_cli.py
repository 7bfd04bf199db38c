"""`vehloc-calibrate site=... image=...`: calibrate a camera, write calibration.json and overlay.png."""

from __future__ import annotations

from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from vehloc.config import build_params, config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.calibration import CalibrationParams
from vehloc.geometry.markers import MarkerDetectionParams
from vehloc.geometry.site import read_site
from vehloc.geometry.site_calibration import calibrate_site, check_mode, write_calibration_files
from vehloc.geometry.video import median_background, read_still


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="calibrate")
@exit_on_error("vehloc-calibrate")
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    detection = build_params(MarkerDetectionParams, OmegaConf.to_container(cfg.detection, resolve=True), "detection")
    params = build_params(CalibrationParams, OmegaConf.to_container(cfg.calibration, resolve=True), "calibration")
    check_mode(cfg.mode)
    site = read_site(cfg.site)
    if cfg.background_frames > 0:
        image = median_background(cfg.image, cfg.background_frames)
    else:
        image = read_still(cfg.image, cfg.frame_index)
    result = calibrate_site(site, image, cfg.mode, detection, params)
    summary = write_calibration_files(result, image, out_dir, cfg.grid_step_mm, {"site": str(cfg.site), "image": str(cfg.image)})
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
