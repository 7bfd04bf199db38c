"""How far the model fit would get if it knew its vehicle's cast shadow: for each benchmark case the pipeline runs to
the stopped car's record as the benchmark does, the silhouette it fitted is taken again at that frame, and the fit is
run from the true pose on that silhouette as extracted and with pixels taken out:

- `as_extracted`: nothing taken out (the fit's own error from the true pose);
- `rendered_shadow_out`: the pixels the renderer darkened by its shadow (`shadow_darkening` above 0.1) outside the
  true car's silhouette (the oracle);
- `cast_shadow_out`: the shadow the car's shape casts (`cast_shadow`, its cast fitted by `fit_cast` to the
  silhouette's doubtful pixels at the true pose) outside the true car's silhouette;
- `doubtful_out_beside`: the silhouette's doubtful pixels (`Silhouette.doubtful`) outside the true car's silhouette;
- `doubtful_out`: the doubtful pixels everywhere (what a fit that cannot tell the shadow from the car can do);
- `true_silhouette`: the true car's silhouette itself (the pixel grid's own limit);
- with the rendered shadow beside the car out, and one more thing put right (what holds the fit back once the shadow
  is known): `shadow_out_car_doubt_full` the car's doubtful pixels weighing 1; `shadow_out_lost_back` the car's pixels
  the silhouette lost put back at 1; `shadow_out_car_full` both; `shadow_out_others_out` the other pixels outside the
  car (not its shadow) taken out.

    python experiments/localization_benchmark/shadow_oracle.py split=dev cases=20 out=runs/shadow_oracle

Settings and seeds as `run.py` (`conf/localization_benchmark.yaml`); the true model is given. Writes `cases.csv`,
`report.md` (per variant: cases within 1 % and 1 deg, the median errors) and `within.png` into `out`.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import hydra
import matplotlib
import numpy as np
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from vehloc.atomic import atomic_path, write_text
from vehloc.benchmark.cases import BenchmarkCase
from vehloc.benchmark.oracle import TrueModelClassifier
from vehloc.benchmark.runner import errors, exact_calibration, localize_stopped_car, true_box
from vehloc.benchmark.suite import BenchmarkSettings, drawn_cases
from vehloc.config import config_dir
from vehloc.errors import exit_on_error
from vehloc.geometry.cast_shadow import cast_shadow, fit_cast
from vehloc.geometry.model_fit import fit_model, silhouette
from vehloc.geometry.pipeline.localize import Localizer
from vehloc.synth.catalog import model_by_id
from vehloc.synth.render import shadow_darkening
from vehloc.synth.scene import scene_lighting
from vehloc.tables import markdown_table

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SHADOW_DARKENING = 0.1
"""A pixel is in the rendered shadow where the shadow takes off more than this share of the road's light."""
VARIANTS = ("as_extracted", "rendered_shadow_out", "cast_shadow_out", "doubtful_out_beside", "doubtful_out",
            "true_silhouette", "shadow_out_car_doubt_full", "shadow_out_lost_back", "shadow_out_car_full",
            "shadow_out_others_out")


def case_errors(case: BenchmarkCase, settings: BenchmarkSettings) -> dict[str, object]:
    """One case's row: the pipeline's own fit error and each variant's, from the true pose."""
    camera_spec = settings.cameras[case.camera_name]
    spec = case.scene_spec(settings.site, camera_spec, settings.draw)
    calibration = exact_calibration(camera_spec)
    localizer = Localizer(TrueModelClassifier(case.model_id), calibration, settings.localize)
    with tempfile.TemporaryDirectory(prefix="vehloc-shadow-oracle-") as folder:
        run = localize_stopped_car(spec, localizer, Path(folder))
    row: dict[str, object] = {"seed": case.seed, "model": model_by_id(case.model_id).name,
                              "camera": case.camera_name, "colour_group": case.colour_group}
    record = run.record
    fit = None if record is None else record.estimate("fit")
    if fit is None:
        return row | {"status": "no fit at the stop"}
    truth, camera = true_box(case), calibration.camera
    row |= {"status": "fitted", **errors("pipeline", fit.box, truth)}
    height_px, width_px = run.frame_bgr.shape[:2]
    roi = record.box_px.enlarged(localizer.params.detector_roi_fraction, width_px, height_px)
    extracted = localizer.extractor.foreground(roi, record.box_px)
    weights, doubtful = extracted.weights, extracted.doubtful
    shape = localizer.classifier.metadata.shape_of(case.model_id)
    car = silhouette(camera, shape, truth, roi, 1)
    rendered = roi.crop(shadow_darkening(camera, model_by_id(case.model_id), case.pose, scene_lighting(spec)))
    cast = fit_cast(camera, shape, truth, roi, doubtful, 1)
    modelled = cast_shadow(camera, shape, truth, cast, roi, 1)
    in_shadow = rendered > SHADOW_DARKENING
    shadow_out = np.where(in_shadow & ~car, 0.0, weights)
    foregrounds = {
        "as_extracted": weights,
        "rendered_shadow_out": shadow_out,
        "cast_shadow_out": np.where(modelled & ~car, 0.0, weights),
        "doubtful_out_beside": np.where(doubtful & ~car, 0.0, weights),
        "doubtful_out": np.where(doubtful, 0.0, weights),
        "true_silhouette": car.astype(np.float32),
        "shadow_out_car_doubt_full": np.where(car & (shadow_out > 0), 1.0, shadow_out),
        "shadow_out_lost_back": np.where(car & (shadow_out == 0), 1.0, shadow_out),
        "shadow_out_car_full": np.where(car, 1.0, shadow_out),
        "shadow_out_others_out": np.where(~car & ~in_shadow, 0.0, shadow_out),
    }
    for name, foreground in foregrounds.items():
        refit = fit_model(camera, foreground, roi, shape, truth, localizer.settings.fit)
        row |= errors(name, refit.box, truth)
    extra = (weights > 0) & ~car
    return row | {"cast_x": float(cast[0]), "cast_y": float(cast[1]), "extra_px": int(extra.sum()),
                  "extra_in_rendered_shadow_px": int((extra & in_shadow).sum()), "car_px": int(car.sum()),
                  "car_lost_px": int((car & (weights == 0)).sum()), "car_doubtful_px": int((car & doubtful).sum())}


def summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per variant (and the pipeline's own fit): cases within the fit's bar, of the fitted, and the median errors."""
    fitted = frame[frame["status"] == "fitted"]
    rows = []
    for name in ("pipeline", *VARIANTS):
        rows.append({"foreground": name, "fitted": len(fitted), "within": int(fitted[f"{name}_within"].sum()),
                     "within_percent": 100.0 * fitted[f"{name}_within"].mean() if len(fitted) else float("nan"),
                     "median_position_pct": fitted[f"{name}_position_pct"].median(),
                     "median_heading_deg": fitted[f"{name}_heading_deg"].median()})
    return pd.DataFrame(rows)


def plot(table: pd.DataFrame, path: Path, title: str) -> None:
    figure, axis = plt.subplots(figsize=(8, 3.6))
    axis.barh(table["foreground"][::-1], table["within_percent"][::-1], color="#4878a8")
    axis.set_xlabel("fits within 1 % and 1 deg (%)")
    axis.set_xlim(0, 100)
    axis.set_title(title, fontsize=9)
    figure.tight_layout()
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", dpi=120)
    plt.close(figure)


@hydra.main(version_base="1.3", config_path=str(config_dir()), config_name="localization_benchmark")
@exit_on_error("shadow_oracle")
def main(cfg: DictConfig) -> None:
    settings = BenchmarkSettings.from_config(OmegaConf.to_container(cfg, resolve=True))
    out_dir = Path(cfg.out)
    cases = drawn_cases(settings)
    start, rows = time.perf_counter(), []
    for number, (_, case) in enumerate(cases, 1):
        rows.append(case_errors(case, settings))
        print(f"[{number}/{len(cases)}] seed {case.seed}: {rows[-1]['status']} ({time.perf_counter() - start:.0f} s)",
              flush=True)
    frame = pd.DataFrame(rows)
    table = summary(frame)
    seeds = ", ".join(f"{split} seeds from {values[0]}" for split, values in settings.seeds.items())
    title = f"The fit from the true pose, the silhouette altered (pipeline: its own fit), {len(frame)} cases ({seeds})"
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "cases.csv", frame.to_csv(index=False, float_format="%.3f"))
    write_text(out_dir / "report.md", f"# {title}\n\n{markdown_table(table)}\n")
    plot(table, out_dir / "within.png", title)
    print(table.to_string(index=False))
    print(f"{len(frame)} cases in {time.perf_counter() - start:.0f} s; wrote {out_dir}")


if __name__ == "__main__":
    main()
