"""`vehloc-scene scene=... out=...`: render a traffic scene with its ground truth and site file."""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from vehloc.config import config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.site import write_site
from vehloc.synth.scene import SceneSpec, write_scene
from vehloc.synth.scene_site import scene_site


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="scene")
@exit_on_error("vehloc-scene")
def main(cfg: DictConfig) -> None:
    spec = SceneSpec.from_dict(OmegaConf.to_container(cfg.scene, resolve=True))
    out_dir = Path(cfg.out)
    video, truth = write_scene(spec, out_dir)
    write_site(out_dir / "site.yaml", scene_site(spec, cfg.site_click_noise_px, spec.seed))
    print(f"wrote {video}, {truth} and {out_dir / 'site.yaml'} ({spec.frame_count} frames)")


if __name__ == "__main__":
    main()
