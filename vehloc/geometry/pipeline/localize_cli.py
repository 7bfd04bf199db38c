"""`vehloc-localize video=... calibration=... model=... [truth=...]`: localize the vehicles of a video and
write the records (CSV + JSON), a picture of each localized vehicle, and the paper's Table 2 when the
scene's ground truth is given."""

from __future__ import annotations

from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from vehloc.config import config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.pipeline.localize import Localizer, stage_params
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.truth import read_scene_truth
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.infer.classifier import VehicleClassifier


@hydra.main(version_base="1.3", config_path=str(config_dir() / "localize"), config_name="localize")
@exit_on_error("vehloc-localize")
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    stages = stage_params(OmegaConf.to_container(cfg, resolve=True))
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
