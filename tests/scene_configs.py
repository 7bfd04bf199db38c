"""Compose the scene configs of `conf/scene/` into SceneSpec objects, as `vehloc-scene` does."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from vehloc.config import config_dir
from vehloc.synth.scene import SceneSpec

TABLE2_SCENES = (
    "table2_middle_0", "table2_middle_30", "table2_middle_minus30",
    "table2_close_0", "table2_close_30", "table2_close_minus30",
)


def scene_spec(name: str, **overrides: object) -> SceneSpec:
    with initialize_config_dir(config_dir=str(config_dir()), version_base="1.3"):
        cfg = compose(config_name="scene", overrides=[f"scene={name}", "out=unused"])
    spec = SceneSpec.from_dict(OmegaConf.to_container(cfg.scene, resolve=True))
    return dataclasses.replace(spec, **overrides)
