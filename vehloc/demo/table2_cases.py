"""One Table 2 case in-process: render the scene, calibrate its camera from its lane markers, localize its car
with an exported classifier against the scene's truth. What `vehloc-demo` and the Table 2 experiment run (the
speed experiments render and calibrate their traffic scenes with the same steps)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import OmegaConf

from vehloc.config import config_dir
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.geometry.site import read_site, site_yaml
from vehloc.geometry.camera_calibration import read_calibration
from vehloc.geometry.pipeline.site_calibration import calibrate_site, write_calibration_files
from vehloc.geometry.truth import read_scene_truth
from vehloc.geometry.pipeline.video import read_still
from vehloc.geometry.pipeline.video_localization import VideoLocalization, localize_video
from vehloc.infer.classifier import VehicleClassifier
from vehloc.synth.scene import SceneSpec, write_scene
from vehloc.synth.scene_site import scene_site
from vehloc.synth.traffic import scene_from_config


def scene_spec(name: str, overrides: Sequence[str] = ()) -> SceneSpec:
    """The scene `conf/scene/<name>.yaml` with Hydra `overrides` (`scene.traffic.seed=3`), composed (inside a running
    vehloc Hydra app or outside one), its traffic block's cars drawn."""
    overrides = [f"scene={name}", "out=unused", *overrides]
    if GlobalHydra.instance().is_initialized():
        cfg = compose("scene", overrides=overrides)
    else:
        with initialize_config_dir(version_base="1.3", config_dir=str(config_dir()), job_name="scene"):
            cfg = compose("scene", overrides=overrides)
    return scene_from_config(OmegaConf.to_container(cfg.scene, resolve=True))


def render_case(spec: SceneSpec, folder: Path, click_noise_px: float = 2.0) -> Path:
    """`folder/scene/`: the video, its truth and its site file; the video's path."""
    video, _ = write_scene(spec, folder / "scene", site_yaml(scene_site(spec, click_noise_px, spec.seed)))
    return video


def calibrate_case(folder: Path, mode: str = "detect", grid_step_mm: float = 1000.0) -> Path:
    """`folder/calibration/`: the camera calibrated from the markers of the scene's first (empty) frame (`mode` as
    `vehloc-calibrate`'s; the overlay's road grid every `grid_step_mm`)."""
    video, site_path = folder / "scene" / "video.avi", folder / "scene" / "site.yaml"
    image = read_still(video)
    result = calibrate_site(read_site(site_path), image, mode, image_name=str(video))
    write_calibration_files(result, image, folder / "calibration", grid_step_mm,
                            {"site": str(site_path), "image": str(video)})
    return folder / "calibration" / "calibration.json"


def render_and_calibrate_case(name: str, folder: Path) -> list[Path]:
    """`folder/scene/` and `folder/calibration/` of the Table 2 scene `name`; the calibration's and the video's
    paths."""
    render_case(scene_spec(name), folder)
    return [calibrate_case(folder), folder / "scene" / "video.avi"]


def localize_case(folder: Path, classifier: VehicleClassifier) -> VideoLocalization:
    """`folder/localize/`: the scene's car localized (default settings) and its Table 2 rows."""
    calibration = read_calibration(folder / "calibration" / "calibration.json")
    truth = read_scene_truth(folder / "scene" / "ground_truth.json")
    return localize_video(Localizer(classifier, calibration), folder / "scene" / "video.avi", folder / "localize",
                          truth, progress=False)


def case_table(folder: Path) -> pd.DataFrame:
    """The Table 2 rows a localized case wrote."""
    return pd.read_csv(folder / "localize" / "table2.csv")
