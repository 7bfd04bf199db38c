"""Compose the scene configs of `conf/scene/` into SceneSpec objects, as `vehloc-scene` does."""

from __future__ import annotations

import dataclasses

from vehloc.demo.scenes import PLATE_SCENES, SIDE_ON_SCENES  # noqa: F401 (the tests' scene lists)
from vehloc.demo.table2_cases import scene_spec as composed_scene
from vehloc.synth.scene import SceneSpec


def scene_spec(name: str, **overrides: object) -> SceneSpec:
    """The scene `conf/scene/<name>.yaml` as `vehloc-scene` composes it, `overrides` replacing its settings."""
    return dataclasses.replace(composed_scene(name), **overrides)


def short_scene(name: str, **overrides: object) -> SceneSpec:
    """A scene with few frames (1 empty, 4 driving, 1 stopped) for fast tests; `overrides` replace settings."""
    return scene_spec(name, **{"empty_frames": 1, "drive_frames": 4, "stopped_frames": 1, **overrides})


def traffic_scene(name: str = "traffic_720p", *overrides: str) -> SceneSpec:
    """A traffic scene of `conf/scene/`, its cars drawn from its `traffic` block; `overrides` are Hydra overrides of
    the scene's settings (`scene.traffic.duration_s=20`)."""
    return composed_scene(name, overrides)
