"""The localization's settings, one path for every caller: `conf/localize/localize.yaml` composed by Hydra (with
the CLI's overrides, or a script's such as `experiment=highway`), every stage group checked into its typed
parameters. `vehloc-localize`, the library's defaults, the demo, the benchmark and the experiments all build their
`LocalizeSettings` this way."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from vehloc.config import ConfigError, build_params, check_choice, check_range, config_dir, params_from_config
from vehloc.geometry.keypoints import DetectorParams
from vehloc.geometry.model_fit import FitParams
from vehloc.geometry.pipeline.track_speed import SpeedParams
from vehloc.geometry.pipeline.tracker import TrackerParams
from vehloc.geometry.pipeline.votes import VOTE_POLICIES
from vehloc.geometry.roi import RoiParams


@dataclass(frozen=True)
class PipelineParams:
    """Settings of the pipeline itself (`conf/localize/pipeline/default.yaml`)."""

    every_frame: bool
    vote_frames: int
    vote_policy: str
    detector_roi_fraction: float
    border_margin_px: int
    min_travel_mm: float
    uncertainty_top_k: int
    uncertainty_min_probability: float
    fit: bool
    fit_from_travel: bool
    fit_from_silhouette: bool
    silhouette_search_mm: tuple[float, float, float]
    keep_start_after_shadow: bool
    heading_from_motion: bool
    motion_window_frames: int
    motion_max_gap_frames: int
    motion_jitter_px: float
    max_motion_sigma_deg: float
    min_speed_sigmas: float
    min_fit_iou: float
    wheels_at_axles: bool
    max_key_points_path_gap_deg: float

    def __post_init__(self) -> None:
        check_choice("vote_policy", self.vote_policy, VOTE_POLICIES)
        check_range("vote_frames", self.vote_frames, 1)
        check_range("detector_roi_fraction", self.detector_roi_fraction, 0.0, 1.0)
        check_range("border_margin_px", self.border_margin_px, 0)
        check_range("min_travel_mm", self.min_travel_mm, 0.0)
        check_range("uncertainty_top_k", self.uncertainty_top_k, 1)
        check_range("uncertainty_min_probability", self.uncertainty_min_probability, 0.0, 1.0)
        check_range("motion_window_frames", self.motion_window_frames, 2)
        check_range("motion_max_gap_frames", self.motion_max_gap_frames, 1)
        check_range("motion_jitter_px", self.motion_jitter_px, 0.0)
        check_range("max_motion_sigma_deg", self.max_motion_sigma_deg, 0.0)
        check_range("min_speed_sigmas", self.min_speed_sigmas, 0.0)
        check_range("min_fit_iou", self.min_fit_iou, 0.0, 1.0)
        check_range("max_key_points_path_gap_deg", self.max_key_points_path_gap_deg, 0.0, 90.0)
        check_range("silhouette_search_mm step", self.silhouette_search_mm[2], 0.0, low_open=True)
        check_range("silhouette_search_mm", self.silhouette_search_mm[0], None, self.silhouette_search_mm[1])

    @classmethod
    def from_config(cls, **overrides: object) -> PipelineParams:
        """The settings of `conf/localize/pipeline/default.yaml`, with `overrides`."""
        return params_from_config(cls, "localize/pipeline/default.yaml", overrides)


STAGE_GROUPS = ("pipeline", "roi", "tracker", "footprint", "plate", "wheels", "fit", "speed")
"""The groups of `conf/localize/` that hold the stages' settings."""


@dataclass(frozen=True)
class LocalizeSettings:
    """Every stage's settings, checked: the pipeline's own, the background model's, the tracker's, the key-point
    detectors', the model fit's and the speeds'."""

    pipeline: PipelineParams
    roi: RoiParams
    tracker: TrackerParams
    detectors: DetectorParams
    fit: FitParams
    speed: SpeedParams

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> LocalizeSettings:
        """From a composed config's stage groups (plain data), each checked; ConfigError naming the first bad
        setting."""
        detectors = DetectorParams.from_mapping({group: values[group] for group in ("footprint", "plate", "wheels")})
        return cls(build_params(PipelineParams, values["pipeline"], "pipeline"),
                   build_params(RoiParams, values["roi"], "roi"),
                   build_params(TrackerParams, values["tracker"], "tracker"), detectors,
                   build_params(FitParams, values["fit"], "fit"), build_params(SpeedParams, values["speed"], "speed"))

    @classmethod
    def compose(cls, overrides: Sequence[str] = ()) -> LocalizeSettings:
        """`conf/localize/localize.yaml` with Hydra overrides (`["experiment=highway", "roi.scale=1"]`), as
        `vehloc-localize` composes it; ConfigError in one line for a bad override."""
        from hydra import compose, initialize_config_dir
        from hydra.core.global_hydra import GlobalHydra
        from hydra.errors import HydraException
        from hydra.initialize import get_gh_backup, restore_gh_from_backup
        from omegaconf import OmegaConf
        from omegaconf.errors import OmegaConfBaseException

        from vehloc.errors import hydra_error_line

        outer = get_gh_backup()  # inside a Hydra app (vehloc-demo), its Hydra is set aside and given back after
        GlobalHydra.instance().clear()
        try:
            with initialize_config_dir(str(config_dir() / "localize"), version_base="1.3"):
                cfg = compose("localize", overrides=list(overrides))
            values = {group: OmegaConf.to_container(cfg[group], resolve=True) for group in STAGE_GROUPS}
        except (HydraException, OmegaConfBaseException) as err:
            raise ConfigError(f"localize settings {list(overrides)}: {hydra_error_line(err)}") from None
        finally:
            restore_gh_from_backup(outer)
        return cls.from_mapping(values)
