"""`vehloc-localize video=... calibration=... model=... [truth=...]`: localize the vehicles of a video and
write the records (CSV + JSON), a picture of each localized vehicle, and the paper's Table 2 when the
scene's ground truth is given.

Every setting is checked and the calibration, the model and the truth are read before the first frame; a bad
override or setting is one line and exit code 1, as in the other CLIs."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_dir
from vehloc.config import ConfigError, build_params, check_range, config_dir
from vehloc.errors import VehlocError, exit_on_error, hydra_main
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.geometry.pipeline.video import video_info
from vehloc.geometry.pipeline.video_localization import localize_video
from vehloc.geometry.truth import SceneTruth, read_scene_truth
from vehloc.infer.classifier import VehicleClassifier
from vehloc.run_manifest import RunManifest

REQUIRED = {"video": "the video to localize", "calibration": "calibration.json of vehloc-calibrate for its camera",
            "model": "an ONNX classifier written by vehloc-export"}


@dataclass(frozen=True)
class LocalizeParams:
    """The top-level settings of `conf/localize.yaml`."""

    video: str
    calibration: str
    model: str
    truth: str | None
    max_frames: int | None
    annotate: bool
    fps: float | None

    def __post_init__(self) -> None:
        if self.max_frames is not None:
            check_range("max_frames", self.max_frames, 1)
        if self.fps is not None:
            check_range("fps", self.fps, 0.0, 1000.0, low_open=True)


def check_truth_is_of_the_video(truth: SceneTruth, truth_path: str, video: str) -> None:
    """VehlocError unless the truth is of a scene filmed as the video is: the same image size and frame count."""
    info = video_info(video)
    camera = truth.camera
    filmed = (camera.width_px, camera.height_px, truth.frame_count)
    if filmed != (info.width_px, info.height_px, info.frame_count):
        raise VehlocError(f"truth {truth_path}: is of a scene of {filmed[0]}x{filmed[1]} px and {filmed[2]} frames "
                          f"({truth.name}), the video {video} has {info.width_px}x{info.height_px} px and "
                          f"{info.frame_count} frames")


@exit_on_error("vehloc-localize")
def _run(cfg: DictConfig) -> None:
    for key, what in REQUIRED.items():
        if OmegaConf.is_missing(cfg, key):
            raise ConfigError(f"{key}=PATH is required: {what}")
    values = OmegaConf.to_container(cfg, resolve=True)
    params = build_params(LocalizeParams, {key: values[key] for key in LocalizeParams.__dataclass_fields__}, "")
    settings = LocalizeSettings.from_mapping(values)
    out_dir = check_output_dir(Path(HydraConfig.get().runtime.output_dir), "run folder")
    calibration = read_calibration(params.calibration)
    localizer = Localizer(VehicleClassifier.from_onnx(params.model), calibration, settings)
    truth = read_scene_truth(params.truth) if params.truth else None
    if truth is not None:
        check_truth_is_of_the_video(truth, params.truth, params.video)
    manifest = RunManifest(out_dir)  # an earlier run's outputs in this folder go; none of anything else
    run = localize_video(localizer, params.video, out_dir, truth, params.max_frames, params.annotate, fps=params.fps)
    manifest.close()
    if run.early_end:
        print(f"vehloc-localize: warning: {run.early_end}", file=sys.stderr, flush=True)
    if not run.records:
        every = localizer.params.every_frame
        print(f"no vehicle {'in view' if every else 'stopped'} in {params.video}: empty records in {out_dir}")
    else:
        print(f"{len(run.records)} record(s), {run.localized} localized: {out_dir / 'records.csv'}")
    if run.speeds:
        print(run.speeds)
    if truth is not None:
        print(f"Table 2 against {params.truth}: {out_dir / 'table2.md'}")


@hydra_main("vehloc-localize", str(config_dir() / "localize"), "localize")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
