"""`vehloc-calibrate site=... image=...`: calibrate a camera from a surveyed site, write calibration.json and
overlay.png; `vehloc-calibrate mode=auto video=... model=...`: calibrate it from the traffic it sees, no site.

Every setting and the site file (or the model file) are checked before the image or video is read; the site's
image_size_px must be the image's; the calibration's files replace an earlier calibration in the run folder
together, when all are complete. An automatic calibration that the traffic cannot give (too few vehicles, none
moving straight) is refused with one line and leaves the run folder as it was."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_dir
from vehloc.config import ConfigError, build_params, check_choice, check_range, config_dir
from vehloc.errors import exit_on_error, hydra_main
from vehloc.geometry.outcome import FailedEstimate
from vehloc.geometry.calibration import CalibrationError, CalibrationParams
from vehloc.geometry.markers import MarkerDetectionParams
from vehloc.geometry.site import read_site
from vehloc.geometry.pipeline.auto_calibrate import (
    AutoCalibrationParams,
    auto_calibrate,
    collect_traffic,
    mean_size_model,
    recognised_models,
)
from vehloc.geometry.pipeline.auto_calibration_files import write_auto_calibration_files
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.site_calibration import CALIBRATION_MODES, calibrate_site, write_calibration_files
from vehloc.geometry.pipeline.video import median_background, read_still
from vehloc.infer.classifier import VehicleClassifier

MODES = (*CALIBRATION_MODES, "auto")
FAR_VP2_WIDTHS = 20.0
"""An automatic calibration whose second vanishing point is further than this many image widths from the image's
centre is written with a warning (the rendered set-ups' are 1.7-12.4 widths away, their focal lengths within 3.5 %;
the real highway clip's 29, its focal length a third off the marker calibration's)."""


@dataclass(frozen=True)
class CalibrateParams:
    """The top-level settings of `conf/calibrate/calibrate.yaml`."""

    site: str | None
    image: str | None
    video: str | None
    model: str | None
    localize: tuple[str, ...]
    frame_index: int
    background_frames: int
    mode: str
    grid_step_mm: float

    def __post_init__(self) -> None:
        check_range("frame_index", self.frame_index, 0)
        check_range("background_frames", self.background_frames, 0, 10_000)
        check_choice("mode", self.mode, MODES)
        check_range("grid_step_mm", self.grid_step_mm, 100.0, 100_000.0)


REQUIRED = {
    "detect": (("site", "the site file"), ("image", "the image or video to calibrate on")),
    "guess": (("site", "the site file"), ("image", "the image or video to calibrate on")),
    "auto": (("video", "the video whose traffic calibrates the camera"),
             ("model", "the exported classifier (.onnx) that recognises the vehicles")),
}


@dataclass(frozen=True)
class CalibrateConfig:
    """Every setting of a calibration: the top level, the marker detector's, the site calibration's, the automatic
    calibration's and (mode=auto) the localization's that find and track the vehicles."""

    params: CalibrateParams
    detection: MarkerDetectionParams
    calibration: CalibrationParams
    auto: AutoCalibrationParams
    localize: LocalizeSettings | None


def check_calibrate_config(cfg: DictConfig) -> CalibrateConfig:
    """Every setting of the calibration, checked before any work (ConfigError naming the first bad one)."""
    groups = ("detection", "calibration", "auto")
    top = {k: v for k, v in OmegaConf.to_container(cfg, resolve=True).items() if k not in groups}
    params = build_params(CalibrateParams, top, "")
    for key, what in REQUIRED[params.mode]:
        if getattr(params, key) in (None, "", "???"):
            raise ConfigError(f"{key}=PATH is required with mode={params.mode}: {what}")
    detection = build_params(MarkerDetectionParams, OmegaConf.to_container(cfg.detection, resolve=True), "detection")
    calibration = build_params(CalibrationParams, OmegaConf.to_container(cfg.calibration, resolve=True), "calibration")
    auto = build_params(AutoCalibrationParams, OmegaConf.to_container(cfg.auto, resolve=True), "auto")
    localize = LocalizeSettings.compose(params.localize) if params.mode == "auto" else None
    return CalibrateConfig(params, detection, calibration, auto, localize)


def run_auto(params: CalibrateParams, auto: AutoCalibrationParams, settings: LocalizeSettings, out_dir: Path) -> None:
    """Calibrate from the video's traffic and write the files; CalibrationError (one line) when it cannot."""
    classifier = VehicleClassifier.from_onnx(params.model)
    evidence = collect_traffic(params.video, auto, settings)
    if evidence.early_end:
        print(f"vehloc-calibrate: warning: {evidence.early_end}", file=sys.stderr, flush=True)
    model_of = (recognised_models(classifier, auto.recognised_size) if auto.scale_source == "recognised"
                else mean_size_model(classifier))
    result = auto_calibrate(evidence, model_of, auto, settings.pipeline.border_margin_px)
    if isinstance(result, FailedEstimate):
        raise CalibrationError(f"{params.video}: no automatic calibration: {result}")
    write_auto_calibration_files(result, evidence.background_bgr, out_dir, params.grid_step_mm,
                                 {"video": params.video, "model": params.model})
    widths = float(np.linalg.norm(result.vp2.point_px - result.pp_px)) / evidence.image_size_px[0]
    if auto.focal_px is None and widths > FAR_VP2_WIDTHS:
        print(f"warning: the second vanishing point is {widths:.0f} image widths from the image's centre: the focal "
              "length, and with it distances along the road, rest on the slight convergence of the edges across the "
              "road and may be far off; where the lens's focal length is known, give it (auto.focal_px=...)")
    print(
        f"focal {result.focal_px:.1f} +- {result.focal_sigma_px:.1f} px ({result.focal_source}), "
        f"camera {result.scale.height_mm / 1000:.2f} m up "
        f"+- {100 * result.scale.sigma_fraction:.1f} % from {result.scale.vehicles} vehicles "
        f"({len(evidence.tracks)} tracked, {evidence.frames} frames); wrote {out_dir / 'calibration.json'} and overlay.png"
    )


@exit_on_error("vehloc-calibrate")
def _run(cfg: DictConfig) -> None:
    out_dir = check_output_dir(Path(HydraConfig.get().runtime.output_dir), "run folder")
    config = check_calibrate_config(cfg)
    params, detection, calibration = config.params, config.detection, config.calibration
    if params.mode == "auto":
        run_auto(params, config.auto, config.localize, out_dir)
        return
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


@hydra_main("vehloc-calibrate", str(config_dir() / "calibrate"), "calibrate")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
