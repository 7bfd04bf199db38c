"""`vehloc-localize video=... calibration=... model=... [truth=...]`: localize the vehicles of a video and
write the records (CSV + JSON), a picture of each localized vehicle, and the paper's Table 2 when the
scene's ground truth is given."""

from __future__ import annotations

from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from vehloc.config import build_params, config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.keypoints import DetectorParams
from vehloc.geometry.localize import Localizer, PipelineParams
from vehloc.geometry.model_fit import FitParams
from vehloc.geometry.roi import RoiParams, TrackerParams
from vehloc.geometry.site_calibration import read_calibration
from vehloc.geometry.truth import read_scene_truth
from vehloc.geometry.video_localization import localize_video
from vehloc.infer.classifier import VehicleClassifier


def _params(cls: type, cfg: DictConfig, key: str):
    return build_params(cls, OmegaConf.to_container(cfg[key], resolve=True), key)


def stage_params(cfg: DictConfig) -> dict[str, object]:
    """The settings of the stage groups of `conf/localize/`, each checked, as `Localizer` keywords."""
    detectors = DetectorParams.from_mapping(
        {group: OmegaConf.to_container(cfg[group], resolve=True) for group in ("footprint", "plate", "wheels")})
    return {"params": _params(PipelineParams, cfg, "pipeline"), "roi": _params(RoiParams, cfg, "roi"),
            "tracker": _params(TrackerParams, cfg, "tracker"), "detectors": detectors, "fit": _params(FitParams, cfg, "fit")}


@hydra.main(version_base="1.3", config_path=str(config_dir() / "localize"), config_name="localize")
@exit_on_error("vehloc-localize")
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    stages = stage_params(cfg)
    calibration = read_calibration(cfg.calibration)
    localizer = Localizer(VehicleClassifier.from_onnx(cfg.model), calibration, **stages)
    truth = read_scene_truth(cfg.truth) if cfg.truth else None
    run = localize_video(localizer, cfg.video, out_dir, truth, cfg.max_frames, cfg.annotate)
    if not run.records:
        every = localizer.params.every_frame
        print(f"no vehicle {'in view' if every else 'stopped'} in {cfg.video}: empty records in {out_dir}")
    else:
        print(f"{len(run.records)} record(s), {run.localized} localized: {out_dir / 'records.csv'}")
    if truth is not None:
        print(f"Table 2 against {cfg.truth}: {out_dir / 'table2.md'}")


if __name__ == "__main__":
    main()
