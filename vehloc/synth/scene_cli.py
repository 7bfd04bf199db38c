"""`vehloc-scene scene=... out=...`: render a traffic scene with its ground truth and site file.

Every setting is checked before the first frame is drawn (the scene's via `SceneSpec`, the site's click noise,
the output folder, every car in view at its target pose, the site computable); the video, the ground truth
and the site file replace those of an earlier scene in `out` together, when all three are complete."""

from __future__ import annotations

import math
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import check_output_dir
from vehloc.config import ConfigError, config_dir
from vehloc.errors import exit_on_error, hydra_main
from vehloc.geometry.site import site_yaml
from vehloc.synth.scene import SceneError, check_cars_in_view, write_scene
from vehloc.synth.scene_site import scene_site
from vehloc.synth.traffic import scene_from_config


@exit_on_error("vehloc-scene")
def _run(cfg: DictConfig) -> None:
    if OmegaConf.is_missing(cfg, "out") or not cfg.get("out"):
        raise ConfigError("out=FOLDER is required: where the scene is written")
    noise = cfg.site_click_noise_px
    if isinstance(noise, bool) or not isinstance(noise, (int, float)) or not math.isfinite(noise) or noise < 0:
        raise ConfigError(f"site_click_noise_px: expected a number >= 0, got {noise!r}")
    spec = scene_from_config(OmegaConf.to_container(cfg.scene, resolve=True))
    out_dir = check_output_dir(Path(cfg.out), "out")
    check_cars_in_view(spec)
    try:
        site = scene_site(spec, float(noise), spec.seed)
    except ValueError as err:
        raise SceneError(f"{err}; no site file can be made") from None
    video, truth = write_scene(spec, out_dir, site_yaml(site))
    print(f"wrote {video}, {truth} and {out_dir / 'site.yaml'} ({spec.frame_count} frames)")


@hydra_main("vehloc-scene", str(config_dir()), "scene")
def main(cfg: DictConfig) -> None:
    _run(cfg)


if __name__ == "__main__":
    main()
