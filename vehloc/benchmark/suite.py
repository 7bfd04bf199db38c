"""The benchmark's settings, read and checked from its composed config before any case runs, and its cases run
side by side in worker processes, each case's row (and picture, where it falls short) gathered in seed order."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from vehloc.atomic import check_output_dir
from vehloc.benchmark.cases import BenchmarkCase, DrawParams, cameras_from_config, draw_case
from vehloc.benchmark.replay import CapturedCase, write_capture
from vehloc.benchmark.runner import CaseOutcome, run_case, thumbnail
from vehloc.benchmark.side_by_side import in_order, worker_classifier
from vehloc.benchmark.visibility import VisibilityParams
from vehloc.config import ConfigError, SettingError, build_params
from vehloc.geometry.pipeline.settings import LocalizeSettings
from vehloc.synth.catalog import model_by_id
from vehloc.synth.road import RoadLayout
from vehloc.synth.scene import CameraSpec

SPLITS = ("dev", "heldout")
CELL_PX = (240, 150)


@dataclass(frozen=True)
class BenchmarkSettings:
    """Everything a benchmark run needs, checked: which seeds, the classifier (None: the true model), the
    site's scene settings, the localization's stage settings (`Localizer` keywords), the cameras, the draw
    ranges and the visibility truth's thresholds."""

    seeds: dict[str, tuple[int, ...]]
    model: Path | None
    workers: int
    site: dict[str, Any]
    localize: LocalizeSettings
    cameras: dict[str, CameraSpec]
    draw: DrawParams
    visibility: VisibilityParams
    capture: Path | None = None

    @classmethod
    def from_config(cls, values: Mapping[str, Any]) -> BenchmarkSettings:
        """From the composed `conf/localization_benchmark.yaml` (resolved to plain data); ConfigError naming the
        setting when one is wrong, and the model file when it is missing."""
        split = values.get("split")
        if split not in (*SPLITS, "both"):
            raise ConfigError(f"split: must be dev, heldout or both, got {split!r}")
        cases, workers = count_setting(values, "cases"), count_setting(values, "workers")
        first = values.get("seeds") or {}
        chosen = SPLITS if split == "both" else (split,)
        for name in chosen:
            if not isinstance(first.get(name), int):
                raise ConfigError(f"seeds.{name}: must be a whole number, got {first.get(name)!r}")
        model = values.get("classifier")
        if model is not None and not Path(model).is_file():
            raise ConfigError(f"classifier={model}: no such file (an ONNX classifier from vehloc-export, or null for the true model)")
        try:
            cameras = cameras_from_config(values.get("cameras"))
            draw = build_params(DrawParams, values.get("draw"), "draw")
            visibility = build_params(VisibilityParams, values.get("visibility"), "visibility")
            RoadLayout(**values["site"]["layout"])
        except SettingError as err:
            raise ConfigError(str(err)) from None
        localize = LocalizeSettings.from_mapping(values["localize"])
        seeds = {name: tuple(range(first[name], first[name] + cases)) for name in chosen}
        capture = values.get("capture")
        capture = None if capture is None else check_output_dir(capture, "capture")
        return cls(seeds, None if model is None else Path(model), workers, dict(values["site"]), localize, cameras,
                   draw, visibility, capture)


def count_setting(values: Mapping[str, Any], name: str) -> int:
    """The setting `name` of `values`, a whole number of at least 1; ConfigError naming it otherwise."""
    value = values.get(name)
    if not isinstance(value, int) or isinstance(value, bool) or value < 1:
        raise ConfigError(f"{name}: must be a whole number >= 1, got {value!r}")
    return value


def _run(settings: BenchmarkSettings, split: str, case: BenchmarkCase) -> CaseOutcome:
    """One case, its capture written where asked (`vehloc.benchmark.replay`); a case that fails on its own is a row
    saying how, not the end of the run."""
    try:
        outcome = run_case(case, split, settings.site, settings.cameras[case.camera_name], settings.draw,
                           settings.visibility, settings.localize, worker_classifier(), settings.capture is not None)
    except Exception as err:  # noqa: BLE001 - one case's failure is that case's result
        return CaseOutcome(failed_row(case, split, settings.cameras[case.camera_name], err), None)
    if settings.capture is not None:
        write_capture(settings.capture, CapturedCase(split, case, outcome.row, outcome.inputs))
        outcome = replace(outcome, inputs=None)
    if outcome.picture_bgr is None:
        return outcome
    row = outcome.row
    caption = f"{case.seed} {model_by_id(case.model_id).model} {case.camera_name}: {short_reason(row)}"
    return CaseOutcome(row, thumbnail(outcome.picture_bgr, CELL_PX, caption))


def failed_row(case: BenchmarkCase, split: str, camera: CameraSpec, err: Exception) -> dict[str, Any]:
    """The row of a case whose run raised: what it was, where its camera stood and what went wrong."""
    return {"split": split, **asdict(case), "model": model_by_id(case.model_id).name, "status": "error",
            "reason": f"{type(err).__name__}: {err}", "localized": False, "key_point": "", "correct": False,
            "key_points_visible": False, "camera_x_mm": camera.position_mm[0], "camera_y_mm": camera.position_mm[1]}


def short_reason(row: Mapping[str, Any]) -> str:
    """A few words on why a case falls short."""
    if row.get("status") == "error":
        return f"error ({row['reason']})"
    if not row["localized"]:
        return "not localized"
    if not row.get("fit_within", False):
        return f"fit {row.get('fit_position_pct', float('nan')):.1f}% {row.get('fit_heading_deg', float('nan')):.1f}deg"
    if not row.get("key_point"):
        return "key points missed"
    return f"paper {row.get('paper_position_pct', float('nan')):.1f}% {row.get('paper_heading_deg', float('nan')):.1f}deg"


def drawn_cases(settings: BenchmarkSettings) -> list[tuple[str, BenchmarkCase]]:
    """Every split's cases, in seed order."""
    layout = RoadLayout(**settings.site["layout"])
    return [(split, draw_case(seed, settings.cameras, layout, settings.draw))
            for split, seeds in settings.seeds.items() for seed in seeds]


def run_benchmark(settings: BenchmarkSettings, report: Callable[[int, int, CaseOutcome], None] | None = None
                  ) -> Iterator[CaseOutcome]:
    """Run every case (`settings.workers` side by side), yielding the outcomes in seed order; `report` is told
    of each as it completes (its number, the total, the outcome)."""
    cases = drawn_cases(settings)
    outcomes = in_order(_run, [(settings, split, case) for split, case in cases], settings.workers, settings.model)
    for number, outcome in enumerate(outcomes, 1):
        if report:
            report(number, len(cases), outcome)
        yield outcome
