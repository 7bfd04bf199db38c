"""Compose the scene configs of `conf/scene/` into SceneSpec objects, as `vehloc-scene` does."""

from __future__ import annotations

import dataclasses

from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from vehloc.config import config_dir
from vehloc.synth.scene import SceneSpec

TABLE2_SCENES = (
    "table2_middle_0", "table2_middle_30", "table2_middle_minus30",
    "table2_close_0", "table2_close_30", "table2_close_minus30",
)
PLATE_SCENES = tuple(f"table2_plate_{distance}_{angle}" for distance in ("middle", "close") for angle in ("0", "30", "minus30"))


def scene_spec(name: str, **overrides: object) -> SceneSpec:
    with initialize_config_dir(config_dir=str(config_dir()), version_base="1.3"):
        cfg = compose(config_name="scene", overrides=[f"scene={name}", "out=unused"])
    spec = SceneSpec.from_dict(OmegaConf.to_container(cfg.scene, resolve=True))
    return dataclasses.replace(spec, **overrides)


def short_scene(name: str, **overrides: object) -> SceneSpec:
    """A scene with few frames (1 empty, 4 driving, 1 stopped) for fast tests; `overrides` replace settings."""
    return scene_spec(name, **{"empty_frames": 1, "drive_frames": 4, "stopped_frames": 1, **overrides})


def traffic_scene(name: str = "traffic_720p", *overrides: str) -> SceneSpec:
    """A traffic scene of `conf/scene/`, its cars drawn from its `traffic` block; `overrides` are Hydra overrides of
    the scene's settings (`scene.traffic.duration_s=20`)."""
    from vehloc.demo.table2_cases import scene_spec as composed_scene

    return composed_scene(name, overrides)
