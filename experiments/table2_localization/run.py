"""The paper's Table 2 on the twelve rendered Table 2 scenes: render each scene, calibrate its camera from its
lane markers, localize its car with an exported classifier against the scene's truth (in-process, as
`vehloc-demo` does: `vehloc.demo.table2_cases`), then gather the cases into one table with both methods.

    python experiments/table2_localization/run.py --model demo_data/model.onnx --out runs/table2

Scenes and calibrations already in `--out` are reused (`--force` redoes them). `--true-class` gives every
track the scene's true model with probability 1 instead of the classifier's vote: the geometry's own error,
apart from the classifier's. Writes into `--out`:
`table2.csv`, `table2_summary.csv` and `table2.md` and, per scene, its folder: `scene/` (video, truth, site),
`calibration/`, and `localize/` with the records, the annotated frame and the bird's-eye figure.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd

from vehloc.demo.scenes import TABLE2_SCENES
from vehloc.demo.table2_cases import calibrate_case, case_table, localize_case, render_case, scene_spec
from vehloc.geometry.pipeline.evaluation import write_table2
from vehloc.geometry.truth import read_scene_truth
from vehloc.infer.classifier import VehicleClassifier
from vehloc.errors import exit_on_error


class TrueClass:
    """A classifier whose every crop is the scene's true model (probability 1); the rest is `classifier`'s."""

    def __init__(self, classifier: VehicleClassifier, model_id: int) -> None:
        self.classifier = classifier
        self.index = [c.model_id for c in classifier.classes].index(model_id)

    def probabilities(self, images, boxes=None) -> np.ndarray:
        one_hot = np.zeros((len(images), len(self.classifier.classes)))
        one_hot[:, self.index] = 1.0
        return one_hot

    def __getattr__(self, name: str):
        return getattr(self.classifier, name)


@exit_on_error("experiments/table2_localization/run.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True, help="a classifier exported by vehloc-export")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--scenes", nargs="+", default=list(TABLE2_SCENES), choices=TABLE2_SCENES, metavar="SCENE")
    parser.add_argument("--force", action="store_true", help="render and calibrate again")
    parser.add_argument("--true-class", action="store_true", help="the true model for every track (no classifier vote)")
    args = parser.parse_args()
    if not args.model.is_file():
        raise SystemExit(f"--model {args.model}: no such file")
    classifier = VehicleClassifier.from_onnx(args.model)

    tables = []
    for number, scene in enumerate(args.scenes, 1):
        start, folder = time.perf_counter(), args.out / scene
        if args.force or not (folder / "scene" / "video.avi").is_file():
            render_case(scene_spec(scene), folder)
        if args.force or not (folder / "calibration" / "calibration.json").is_file():
            calibrate_case(folder)
        if args.true_class:
            truth = read_scene_truth(folder / "scene" / "ground_truth.json")
            localize_case(folder, TrueClass(classifier, truth.cars[0].model_id))
        else:
            localize_case(folder, classifier)
        tables.append(case_table(folder))
        print(f"[{number}/{len(args.scenes)}] {scene}: {time.perf_counter() - start:.0f} s", flush=True)
    table = pd.concat(tables, ignore_index=True)
    written = write_table2(table, args.out, f"Table 2: {len(args.scenes)} scenes, model {args.model.name}"
                          + (", the true class given" if args.true_class else ""))
    print((args.out / "table2.md").read_text())
    print("wrote " + ", ".join(str(p) for p in written))


if __name__ == "__main__":
    main()
