"""Milliseconds per 1280x720 frame of each geometry stage, on a rendered Table 2 scene.

    python experiments/bench_geometry.py --out outputs/bench_geometry [--repeats 20]

Writes `geometry_stages.csv` and `geometry_stages.md` to the output folder.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from vehloc.config import config_dir
from vehloc.geometry.calibration import calibrate
from vehloc.geometry.markers import detect_markers
from vehloc.geometry.pipeline.tracker import StoppedVehicleTracker
from vehloc.geometry.roi import VehicleRoiExtractor
from vehloc.synth.render import render_car
from vehloc.synth.road import render_road
from vehloc.synth.scene import SceneSpec, render_frames
from vehloc.synth.scene_site import scene_site
from vehloc.tables import markdown_table
from vehloc.errors import exit_on_error



def _time_ms(function: Callable[[], object], repeats: int) -> list[float]:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(1000 * (time.perf_counter() - start))
    return times


@exit_on_error("experiments/bench_geometry.py")
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("outputs/bench_geometry"))
    parser.add_argument("--scene", default="table2_close_30")
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()

    with initialize_config_dir(config_dir=str(config_dir()), version_base="1.3"):
        cfg = compose(config_name="scene", overrides=[f"scene={args.scene}", "out=unused"])
    spec = SceneSpec.from_dict(OmegaConf.to_container(cfg.scene, resolve=True))
    camera = spec.camera.camera()
    road = render_road(camera, spec.layout, np.random.default_rng(0))
    site = scene_site(spec)
    markers = detect_markers(road)
    car = spec.cars[0]
    frames = [frame for frame, _ in render_frames(spec)]

    extractor, tracker = VehicleRoiExtractor(), StoppedVehicleTracker(vote_frames=1)
    roi_ms, track_ms = [], []
    for index, frame in enumerate(frames):
        start = time.perf_counter()
        boxes = extractor.apply(frame)
        roi_ms.append(1000 * (time.perf_counter() - start))
        start = time.perf_counter()
        tracker.update(boxes, index)
        track_ms.append(1000 * (time.perf_counter() - start))

    stages = {
        "render road (scene background)": _time_ms(lambda: render_road(camera, spec.layout, np.random.default_rng(0)), args.repeats),
        "render car over the road (supersampled, shadow)": _time_ms(
            lambda: render_car(car.model, car.paint[1], car.target_pose, camera, road), args.repeats
        ),
        "lane-marker detection": _time_ms(lambda: detect_markers(road), args.repeats),
        "calibration (match, RANSAC, edge refinement)": _time_ms(lambda: calibrate(markers, site, image_bgr=road), args.repeats),
        "vehicle ROI (MOG2, shadows, blobs) per frame": roi_ms[spec.empty_frames:],
        "ROI during background learning per frame": roi_ms[: spec.empty_frames],
        "stop tracker update per frame": track_ms,
    }
    rows = [
        {"stage": name, "median_ms": float(np.median(ms)), "p90_ms": float(np.percentile(ms, 90)), "runs": len(ms)}
        for name, ms in stages.items()
    ]
    table = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out / "geometry_stages.csv", index=False)
    header = f"Geometry stages on `{args.scene}` ({camera.width_px}x{camera.height_px}), milliseconds\n\n"
    markdown = header + markdown_table(table, "{:.1f}") + "\n"
    (args.out / "geometry_stages.md").write_text(markdown)
    print(markdown)


if __name__ == "__main__":
    main()
