"""The files of an automatic calibration: `calibration.json` (the contract `read_calibration` reads, with the camera,
the 1-sigmas and the benchmark's block), `vehicles.csv` (each scaling vehicle's model and estimate), `image.png` (the
road without traffic) and `overlay.png` (the recovered road grid and the lines to the two vanishing points), all
renamed into place together."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from vehloc.atomic import atomic_paths, encode_image
from vehloc.geometry.pipeline.auto_calibrate import AutoCalibration
from vehloc.geometry.pipeline.overlay import SCALE, SHIFT, draw_grid
from vehloc.geometry.vanishing import Segments

if TYPE_CHECKING:
    import pandas as pd

DRAWN_SEGMENTS = 40
VP1_BGR, VP2_BGR = (0, 200, 0), (255, 0, 255)
MIN_OVERLAY_WIDTH_PX = 960
"""A smaller image is enlarged (by a whole factor) before the overlay is drawn on it."""


def _draw_towards(canvas: np.ndarray, segments: Segments, point_h: np.ndarray, colour: tuple[int, int, int],
                  zoom: int) -> None:
    """From the heaviest segments' middles, lines towards the homogeneous point (to the frame's edge), on an image
    enlarged `zoom` times."""
    diagonal = float(np.hypot(*canvas.shape[:2]))
    point_h = np.array([point_h[0] * zoom, point_h[1] * zoom, point_h[2]])
    for i in np.argsort(-segments.weights)[:DRAWN_SEGMENTS]:
        start = segments.points_px[i] * zoom
        towards = point_h[:2] - point_h[2] * start
        if point_h[2] < 0:
            towards = -towards
        length = np.linalg.norm(towards)
        if length == 0:
            continue
        reach = min(diagonal, length / abs(point_h[2])) if abs(point_h[2]) > 0 else diagonal
        end = start + towards / length * reach
        cv2.line(canvas, (int(start[0] * SCALE), int(start[1] * SCALE)), (int(end[0] * SCALE), int(end[1] * SCALE)),
                 colour, 1, cv2.LINE_AA, SHIFT)


def draw_auto_calibration(background_bgr: np.ndarray, result: AutoCalibration, grid_step_mm: float) -> np.ndarray:
    """The road without traffic (enlarged to at least `MIN_OVERLAY_WIDTH_PX`), the road grid of the recovered camera
    (cyan, `grid_step_mm`), lines to the first
    vanishing point from the longest segments it was found on (green: road lines or paths of points on the vehicles)
    and to the second from the longest edges across (magenta)."""
    camera = result.camera
    height, width = background_bgr.shape[:2]
    zoom = max(1, int(np.ceil(MIN_OVERLAY_WIDTH_PX / width)))
    canvas = cv2.resize(background_bgr, (width * zoom, height * zoom), interpolation=cv2.INTER_LINEAR)
    near = camera.image_to_road(np.array([[(width - 1) / 2, height - 1.0]]))[0]
    extent = np.array([[near[0] - 15000.0, near[1]], [near[0] + 15000.0, near[1] + 100_000.0]])
    to_image = camera.road_to_image()
    draw_grid(canvas, lambda points_mm: (to_image(points_mm) + 0.5) * zoom - 0.5, extent, grid_step_mm)
    _draw_towards(canvas, result.along.subset(result.vp1.inliers), result.vp1.point_h, VP1_BGR, zoom)
    _draw_towards(canvas, result.across.subset(result.vp2.inliers), result.vp2.point_h, VP2_BGR, zoom)
    text = (f"f {result.focal_px:.0f} px, height {result.scale.height_mm / 1000:.2f} m "
            f"+- {100 * result.scale.sigma_fraction:.1f} %, {result.scale.vehicles} vehicles")
    cv2.putText(canvas, text, (10, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 0), 4, cv2.LINE_AA)
    cv2.putText(canvas, text, (10, 28), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2, cv2.LINE_AA)
    return canvas


def vehicles_table(result: AutoCalibration) -> pd.DataFrame:
    """One row per vehicle that scaled the camera: its track, model, views, camera height and what it says of the
    scale against the combined one."""
    import pandas as pd  # imported on use: a CLI checks its input before loading pandas

    return pd.DataFrame([{
        "track_id": v.track_id, "model": v.model, "model_id": v.model_id, "heading_deg": v.heading_deg,
        "views": v.views, "camera_height_mm": v.height_mm, "size_doubt": v.size_doubt,
        "relative_to_combined": v.height_mm / result.scale.height_mm - 1.0,
    } for v in result.vehicles])


def write_auto_calibration_files(result: AutoCalibration, background_bgr: np.ndarray, out_dir: Path,
                                 grid_step_mm: float, sources: dict[str, str]) -> dict[str, object]:
    """The four files, each to a temporary sibling first and renamed into place together; the summary written."""
    summary = dict(sources) | result.summary()
    contents = {
        "image.png": encode_image("image.png", background_bgr),
        "calibration.json": (json.dumps(summary, indent=2) + "\n").encode("utf-8"),
        "overlay.png": encode_image("overlay.png", draw_auto_calibration(background_bgr, result, grid_step_mm)),
        "vehicles.csv": vehicles_table(result).to_csv(index=False, float_format="%.4f").encode("utf-8"),
    }
    with atomic_paths([out_dir / name for name in contents]) as temporaries:
        for temporary, data in zip(temporaries, contents.values()):
            temporary.write_bytes(data)
    return summary
