"""`vehloc-calibrate site=... image=...`: calibrate a camera, write calibration.json and overlay.png.

Every setting and the site file are checked before the image is read; the site's image_size_px must be the
image's; calibration.json, overlay.png and image.png replace an earlier calibration in the run folder together,
when all three are complete."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_dir
from vehloc.config import ConfigError, build_params, check_choice, check_range, config_dir
from vehloc.errors import exit_on_error, hydra_main
from vehloc.geometry.calibration import CalibrationParams
from vehloc.geometry.markers import MarkerDetectionParams
from vehloc.geometry.site import read_site
from vehloc.geometry.pipeline.site_calibration import CALIBRATION_MODES, calibrate_site, write_calibration_files
from vehloc.geometry.pipeline.video import median_background, read_still


@dataclass(frozen=True)
class CalibrateParams:
    """The top-level settings of `conf/calibrate.yaml`."""

    site: str
    image: str
    frame_index: int
    background_frames: int
    mode: str
    grid_step_mm: float

    def __post_init__(self) -> None:
        check_range("frame_index", self.frame_index, 0)
        check_range("background_frames", self.background_frames, 0, 10_000)
        check_choice("mode", self.mode, CALIBRATION_MODES)
        check_range("grid_step_mm", self.grid_step_mm, 100.0, 100_000.0)


def check_calibrate_config(cfg: DictConfig) -> tuple[CalibrateParams, MarkerDetectionParams, CalibrationParams]:
    """Every setting of the calibration, checked before any work (ConfigError naming the first bad one)."""
    for key, what in (("site", "the site file"), ("image", "the image or video to calibrate on")):
        if OmegaConf.is_missing(cfg, key):
            raise ConfigError(f"{key}=PATH is required: {what}")
    top = {k: v for k, v in OmegaConf.to_container(cfg, resolve=True).items() if k not in ("detection", "calibration")}
    params = build_params(CalibrateParams, top, "")
    detection = build_params(MarkerDetectionParams, OmegaConf.to_container(cfg.detection, resolve=True), "detection")
    calibration = build_params(CalibrationParams, OmegaConf.to_container(cfg.calibration, resolve=True), "calibration")
    return params, detection, calibration


@exit_on_error("vehloc-calibrate")
def _run(cfg: DictConfig) -> None:
    out_dir = check_output_dir(Path(HydraConfig.get().runtime.output_dir), "run folder")
    params, detection, calibration = check_calibrate_config(cfg)
    site = read_site(params.site)
    if params.background_frames > 0:
        image = median_background(params.image, params.background_frames)
    else:
        image = read_still(params.image, params.frame_index)
    result = calibrate_site(site, image, params.mode, detection, calibration, image_name=params.image)
    summary = write_calibration_files(result, image, out_dir, params.grid_step_mm,
                                      {"site": params.site, "image": params.image})
    kind = "clicked points" if params.mode == "guess" else "corners"
    edge = summary["median_edge_px"]
    print(
        f"{summary['inliers']}/{summary['matched_corners']} {kind} inliers, RMS {summary['rms_reprojection_px']:.2f} px "
        f"/ {summary['rms_road_error_mm']:.0f} mm on the road"
        + (f", median edge distance {edge:.2f} px" if edge is not None else "")
        + f"; wrote {out_dir / 'calibration.json'} and overlay.png"
    )


@hydra_main("vehloc-calibrate", str(config_dir()), "calibrate")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
