"""The CompCars-format demo set: catalog cars from random viewpoints over random backgrounds.

By default the viewpoints are those of a camera above a road (fronts and rears, seen from above), the
views the localisation pipeline classifies; ``views="any"`` goes all round the car, like web photos.

Every image is a pure function of (seed, model id, index), so the bytes written do not depend on the
number of worker processes.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.context
import multiprocessing.pool
import signal
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from vehloc.atomic import atomic_dir, check_output_dir
from vehloc.data.attributes import write_attributes
from vehloc.data.compcars import write_label, write_split_list
from vehloc.data.matfile import write_make_model_names
from vehloc.data.shapes import SHAPES_FILE, write_shapes
from vehloc.data.specs import write_specs_csv
from vehloc.errors import VehlocError
from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.background import random_background
from vehloc.synth.body import catalog_shapes
from vehloc.synth.catalog import (
    CATALOG,
    RGB,
    CarModel,
    make_names,
    model_attributes,
    model_by_id,
    model_names,
    vehicle_specs,
)
from vehloc.synth.render import CarPose, CarRender, Lighting, render_car

IMAGE_SIZE_PX = (320, 240)
MARKER_FILE = ".vehloc-demo"


def viewpoint_code(azimuth_deg: float) -> int:
    """CompCars viewpoint of a camera at ``azimuth_deg`` around the car from its front (either way).

    1 front (within 22.5 deg of the front), 4 front-side (22.5-67.5), 3 side (67.5-112.5),
    5 rear-side (112.5-157.5), 2 rear (beyond 157.5).
    """
    off_front = abs((azimuth_deg + 180.0) % 360.0 - 180.0)
    for limit, code in ((22.5, 1), (67.5, 4), (112.5, 3), (157.5, 5)):
        if off_front < limit:
            return code
    return 2


@dataclass(frozen=True, eq=False)
class DemoScene:
    """Everything one demo image is made from.

    ``azimuth_deg``: direction from the car's centre to the camera, seen from above, counter-clockwise
    from the car's front.
    """

    model: CarModel
    body_rgb: RGB
    pose: CarPose
    camera: PinholeCamera
    azimuth_deg: float
    lighting: Lighting
    background_bgr: np.ndarray
    shadow_strength: float
    noise_sigma: float
    blur_sigma: float
    jpeg_quality: int

    @property
    def viewpoint(self) -> int:
        return viewpoint_code(self.azimuth_deg)


def image_rng(seed: int, model_id: int, index: int) -> np.random.Generator:
    """The random stream of one image."""
    return np.random.default_rng([seed, model_id, index])


def _car_box_corners_mm(model: CarModel) -> np.ndarray:
    """Corners of a box around the car (mirrors included), car frame."""
    hl, hw = model.length_mm / 2, model.width_mm / 2 + 200.0
    return np.array([[x, y, z] for x in (-hl, hl) for y in (-hw, hw) for z in (0.0, model.height_mm)])


VIEWS = ("any", "traffic", "road")
"""Viewpoint ranges: "any" direction around the car at 0-35 deg elevation (web photos); "traffic": within 30
deg of the car's front or rear at 8-35 deg elevation (a camera above a road, cars driving towards or away
from it); "road": within 30 deg of the car's front, rear or either side at 8-35 deg elevation (a camera
above a road and cars along it or across it, as the paper's Table 2 puts them)."""


def _camera_direction_deg(rng: np.random.Generator, views: str) -> tuple[float, float]:
    """Azimuth from the car's front (counter-clockwise) and elevation of the camera, in degrees."""
    if views == "any":
        return float(rng.uniform(0, 360)), float(rng.uniform(0, 35))
    if views == "traffic":
        return float(rng.choice([0.0, 180.0]) + rng.uniform(-30, 30)), float(rng.uniform(8, 35))
    if views == "road":
        return float(rng.choice([0.0, 90.0, 180.0, 270.0]) + rng.uniform(-30, 30)), float(rng.uniform(8, 35))
    raise ValueError(f"views must be one of {VIEWS}, not {views!r}")


def sample_scene(model: CarModel, seed: int, index: int, views: str = "traffic") -> DemoScene:
    """Draw the viewpoint, framing, light, colour, background and degradations of one image."""
    rng = image_rng(seed, model.model_id, index)
    width, height = IMAGE_SIZE_PX
    pose = CarPose(0.0, 0.0, float(rng.uniform(0, 360)))
    azimuth_from_front_deg, elevation_deg = _camera_direction_deg(rng, views)
    direction = np.radians(pose.heading_deg + azimuth_from_front_deg)
    elevation = np.radians(elevation_deg)
    distance_mm = model.length_mm * rng.uniform(1.4, 3.0)
    target = np.array(
        [*rng.uniform(-0.04, 0.04, 2) * model.length_mm, model.height_mm * rng.uniform(0.35, 0.55)]
    )
    position = target + distance_mm * np.array(
        [np.cos(elevation) * np.cos(direction), np.cos(elevation) * np.sin(direction), np.sin(elevation)]
    )
    to_camera = position[:2] - np.array([pose.x_mm, pose.y_mm])
    azimuth_deg = float(np.degrees(np.arctan2(to_camera[1], to_camera[0])) - pose.heading_deg) % 360.0
    roll_deg = float(rng.uniform(-4, 4))
    unit = PinholeCamera.look_at(position, target, 1.0, width, height, roll_deg, principal_px=(0.0, 0.0))
    extent = unit.project(pose.car_to_world(_car_box_corners_mm(model)))
    low, high = extent.min(axis=0), extent.max(axis=0)
    margin_px = 3.0
    fill = rng.uniform(0.6, 0.92)
    focal_px = fill * min(
        (width - 2 * margin_px) / (high[0] - low[0]), (height - 2 * margin_px) / (high[1] - low[1])
    )
    cx = rng.uniform(margin_px - focal_px * low[0], width - 1 - margin_px - focal_px * high[0])
    cy = rng.uniform(margin_px - focal_px * low[1], height - 1 - margin_px - focal_px * high[1])
    camera = PinholeCamera.look_at(position, target, focal_px, width, height, roll_deg, principal_px=(cx, cy))

    _, rgb = model.palette[int(rng.integers(len(model.palette)))]
    tint = rng.uniform(0.9, 1.08) * np.array(rgb) + rng.uniform(-3, 3, 3)
    body_rgb = tuple(int(v) for v in np.clip(np.round(tint), 0, 255))
    lighting = Lighting.from_angles(
        rng.uniform(0, 360), rng.uniform(25, 75), rng.uniform(0.35, 0.6), rng.uniform(0.45, 0.8)
    )
    road_heading = pose.heading_deg + (rng.uniform(-10, 10) if rng.random() < 0.7 else rng.uniform(0, 180))
    background = random_background(rng, camera, np.zeros(3), road_heading)
    return DemoScene(
        model=model,
        body_rgb=body_rgb,
        pose=pose,
        camera=camera,
        azimuth_deg=azimuth_deg,
        lighting=lighting,
        background_bgr=background,
        shadow_strength=float(rng.uniform(0.3, 0.7)),
        noise_sigma=float(rng.uniform(1.0, 6.0)),
        blur_sigma=float(rng.uniform(0.5, 1.3)) if rng.random() < 0.3 else 0.0,
        jpeg_quality=int(rng.integers(70, 96)),
    )


def render_scene(scene: DemoScene) -> CarRender:
    """The clean render of a scene (before noise, blur and JPEG)."""
    return render_car(
        scene.model,
        scene.body_rgb,
        scene.pose,
        scene.camera,
        scene.background_bgr,
        scene.lighting,
        scene.shadow_strength,
    )


def encode_scene(scene: DemoScene, render: CarRender, seed: int, index: int) -> bytes:
    """Degrade the render (noise, occasional blur) and encode it as JPEG."""
    rng = np.random.default_rng([seed, scene.model.model_id, index, 1])
    image = render.image_bgr.astype(np.float32)
    if scene.blur_sigma > 0:
        image = cv2.GaussianBlur(image, (0, 0), scene.blur_sigma)
    image += scene.noise_sigma * rng.standard_normal(image.shape, dtype=np.float32)
    image = np.clip(np.round(image), 0, 255).astype(np.uint8)
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, scene.jpeg_quality])
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    return encoded.tobytes()


def relative_image_path(model: CarModel, index: int) -> str:
    """`make/model/year/name.jpg` of one demo image."""
    return f"{model.make_id}/{model.model_id}/{model.year}/{index:04d}.jpg"


def _write_image(task: tuple[Path, int, int, int, str]) -> str:
    root, seed, model_id, index, views = task
    model = model_by_id(model_id)
    scene = sample_scene(model, seed, index, views)
    render = render_scene(scene)
    if render.box is None:
        raise RuntimeError(f"{model.name} image {index}: the car is not in the frame")
    rel = relative_image_path(model, index)
    image_path = root / "image" / rel
    image_path.parent.mkdir(parents=True, exist_ok=True)
    image_path.write_bytes(encode_scene(scene, render, seed, index))
    write_label((root / "label" / rel).with_suffix(".txt"), scene.viewpoint, render.box)
    return rel


def _init_worker() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    cv2.setNumThreads(1)


def split_indices(
    seed: int, model_id: int, per_model: int, test_fraction: float
) -> tuple[list[int], list[int]]:
    """Train and test image indices of one model (every model gets at least one of each)."""
    n_test = min(max(1, round(per_model * test_fraction)), per_model - 1)
    rng = np.random.default_rng([seed, model_id, per_model, 0, 1])
    test = set(rng.choice(per_model, size=n_test, replace=False).tolist())
    return [i for i in range(per_model) if i not in test], sorted(test)


MAX_SEED = 2**32 - 1


def check_demo_root(out_dir: Path) -> None:
    """VehlocError unless a demo set can be written to `out_dir`: a new folder, an empty one or one an earlier
    make-demo wrote (never a foreign folder), whose parent folder can be written."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise VehlocError(f"{out_dir}: is a file, not a folder; choose a new or empty folder")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not (out_dir / MARKER_FILE).is_file():
        raise VehlocError(f"{out_dir}: not empty and not a vehloc demo set; choose a new or empty folder")
    check_output_dir(out_dir.parent, "the folder of the demo set")


def _pool(context: multiprocessing.context.BaseContext, workers: int) -> multiprocessing.pool.Pool:
    """A pool of spawned workers that ignore SIGINT from the moment they start (Ctrl-C reaches every process
    of the terminal's group; the parent alone handles it, and ends the pool)."""
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)  # inherited by the spawned interpreters
    try:
        return context.Pool(workers, initializer=_init_worker)
    finally:
        signal.signal(signal.SIGINT, previous)


def make_demo_set(
    out_dir: Path,
    per_model: int = 240,
    seed: int = 0,
    test_fraction: float = 0.25,
    workers: int = 2,
    views: str = "traffic",
) -> Path:
    """Write the CompCars-format demo set under ``out_dir`` and return it.

    ``views``: "traffic" or "any" (see `VIEWS`). Images, labels (true viewpoint, tight box), stratified
    split lists, `misc/make_model_name.mat`, `misc/attributes.txt`, `specs.csv` and the models' shapes,
    `misc/vehicle_shapes.json`. The set is written into a temporary sibling folder and takes the place of
    ``out_dir`` only when complete: an interrupt or a failure leaves an earlier set there untouched, and the
    temporary folder of a killed run is removed by the next. A folder written by an earlier run is replaced;
    any other non-empty folder is refused. With ``workers`` > 1 the images are drawn in spawned processes, so
    a script calling this must do so under ``if __name__ == "__main__":``.
    """
    out_dir = Path(out_dir)
    if per_model < 2:
        raise ValueError("per_model must be at least 2 so that every model is in both splits")
    if not 0 < test_fraction < 1:
        raise ValueError("test_fraction must be in (0, 1)")
    if views not in VIEWS:
        raise ValueError(f"views must be one of {VIEWS}, not {views!r}")
    if not 0 <= seed <= MAX_SEED or workers < 1:
        raise ValueError(f"seed must be in [0, {MAX_SEED}] and workers >= 1, got {seed} and {workers}")
    check_demo_root(out_dir)
    with atomic_dir(out_dir) as staging:
        _write_demo_set(staging, per_model, seed, test_fraction, workers, views)
    return out_dir


def _write_demo_set(root: Path, per_model: int, seed: int, test_fraction: float, workers: int, views: str) -> None:
    tasks = [(root, seed, m.model_id, i, views) for m in CATALOG for i in range(per_model)]
    progress = dict(total=len(tasks), desc="demo images", unit="img", disable=None)  # silent when not a terminal
    if workers <= 1:
        rel_paths = [_write_image(task) for task in tqdm(tasks, **progress)]
    else:
        with _pool(multiprocessing.get_context("spawn"), workers) as pool:
            rel_paths = list(tqdm(pool.imap(_write_image, tasks, chunksize=4), **progress))

    train, test = [], []
    for m in CATALOG:
        train_idx, test_idx = split_indices(seed, m.model_id, per_model, test_fraction)
        train += [relative_image_path(m, i) for i in train_idx]
        test += [relative_image_path(m, i) for i in test_idx]
    assert sorted(train + test) == sorted(rel_paths)
    split_dir = root / "train_test_split" / "classification"
    write_split_list(split_dir / "train.txt", train)
    write_split_list(split_dir / "test.txt", test)
    write_make_model_names(root / "misc" / "make_model_name.mat", make_names(), model_names())
    write_attributes(root / "misc" / "attributes.txt", model_attributes())
    write_specs_csv(root / "specs.csv", vehicle_specs())
    write_shapes(root / SHAPES_FILE, catalog_shapes())
    (root / MARKER_FILE).write_text("written by vehloc.synth.demo_set.make_demo_set\n")
