"""The paper's Table 2 on the twelve rendered Table 2 scenes: render each scene (`vehloc-scene`), calibrate its
camera from its lane markers (`vehloc-calibrate`), localize its car with an exported classifier
(`vehloc-localize ... truth=`), then gather the cases into one table with both methods.

    python experiments/table2_localization/run.py --model demo_data/model.onnx --out runs/table2

Scenes and calibrations already in `--out` are reused (`--force` redoes them). Writes into `--out`:
`table2.csv`, `table2_summary.csv`, `table2.md` and, per scene, its folder with the localization's bird's-eye
figure and annotated frame.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

from vehloc.geometry.evaluation import write_table2

SCENES = tuple(f"table2_{distance}_{angle}" for distance in ("middle", "close") for angle in ("0", "30", "minus30")) + \
    tuple(f"table2_plate_{distance}_{angle}" for distance in ("middle", "close") for angle in ("0", "30", "minus30"))
BIN = Path(sys.executable).parent


def run(command: list[str], log: Path) -> None:
    """Run one vehloc command, its output into `log`; stop with its last lines when it fails."""
    with log.open("w") as out:
        done = subprocess.run(command, stdout=out, stderr=subprocess.STDOUT)
    if done.returncode:
        tail = log.read_text().strip().splitlines()[-3:]
        raise SystemExit(f"{' '.join(command[:2])} failed (exit {done.returncode}): " + " | ".join(tail))


def scene_table(scene: str, model: Path, out: Path, force: bool) -> pd.DataFrame:
    folder = out / scene
    if force and folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True, exist_ok=True)
    video, calibration = folder / "scene" / "video.avi", folder / "calibration" / "calibration.json"
    if not video.is_file():
        run([str(BIN / "vehloc-scene"), f"scene={scene}", f"out={folder / 'scene'}"], folder / "scene.log")
    if not calibration.is_file():
        run([str(BIN / "vehloc-calibrate"), f"site={folder / 'scene' / 'site.yaml'}", f"image={video}",
             f"hydra.run.dir={folder / 'calibration'}"], folder / "calibrate.log")
    run([str(BIN / "vehloc-localize"), f"video={video}", f"calibration={calibration}", f"model={model}",
         f"truth={folder / 'scene' / 'ground_truth.json'}", f"hydra.run.dir={folder / 'localize'}"],
        folder / "localize.log")
    return pd.read_csv(folder / "localize" / "table2.csv")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True, help="a classifier exported by vehloc-export")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES, metavar="SCENE")
    parser.add_argument("--force", action="store_true", help="render and calibrate again")
    args = parser.parse_args()
    if not args.model.is_file():
        raise SystemExit(f"--model {args.model}: no such file")

    tables = []
    for number, scene in enumerate(args.scenes, 1):
        start = time.perf_counter()
        tables.append(scene_table(scene, args.model.resolve(), args.out, args.force))
        print(f"[{number}/{len(args.scenes)}] {scene}: {time.perf_counter() - start:.0f} s", flush=True)
    table = pd.concat(tables, ignore_index=True)
    written = write_table2(table, args.out, f"Table 2: {len(args.scenes)} scenes, model {args.model.name}")
    print((args.out / "table2.md").read_text())
    print("wrote " + ", ".join(str(p) for p in written))


if __name__ == "__main__":
    main()
