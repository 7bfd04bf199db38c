"""Pictures of a localization: the estimated box drawn back into the camera image, and the bird's-eye view of
true and estimated footprints on the road (the paper's Fig. 9 and 13)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from vehloc.atomic import atomic_path
from vehloc.geometry.camera import PinholeCamera
from vehloc.geometry.placement import VehicleBox
from vehloc.geometry.projective import ProjectiveTransform

SHIFT = 4
CUBOID_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
METHOD_COLOURS_BGR = {"paper": (60, 200, 60), "fit": (255, 160, 40), "truth": (40, 40, 230)}
METHOD_STYLES = {"truth": ("tab:red", "o", "true"), "paper": ("tab:green", "x", "paper's method"),
                 "fit": ("tab:blue", "+", "model fit")}


def _point(pixel: np.ndarray) -> tuple[int, int]:
    return int(round(pixel[0] * (1 << SHIFT))), int(round(pixel[1] * (1 << SHIFT)))


def draw_cuboid(image: np.ndarray, camera: PinholeCamera, box: VehicleBox, height_mm: float,
                colour_bgr: tuple[int, int, int], thickness: int = 2) -> None:
    """The box of `box`'s footprint and `height_mm`, projected into `image` (in place); its front face drawn
    crossed so that the heading shows."""
    corners = camera.project(box.cuboid_mm(height_mm))
    edges = CUBOID_EDGES + [(0, 5), (1, 4)]
    for a, b in edges:
        if np.all(np.isfinite(corners[[a, b]])):
            cv2.line(image, _point(corners[a]), _point(corners[b]), colour_bgr, thickness, cv2.LINE_AA, SHIFT)


def draw_footprint(image: np.ndarray, road_to_image: ProjectiveTransform, box: VehicleBox,
                   colour_bgr: tuple[int, int, int], thickness: int = 2) -> None:
    """The footprint's outline on the road, drawn into `image` through the road homography (in place)."""
    corners = road_to_image(box.corners_mm())
    for a in range(4):
        b = (a + 1) % 4
        if np.all(np.isfinite(corners[[a, b]])):
            cv2.line(image, _point(corners[a]), _point(corners[b]), colour_bgr, thickness, cv2.LINE_AA, SHIFT)


def write_birds_eye(path: Path, boxes: dict[str, VehicleBox], title: str, tyres_mm: np.ndarray | None = None) -> Path:
    """A bird's-eye PNG of footprints (keys `truth`, `paper`, `fit`) on the road, X to the right and Y up,
    with the tyre positions the truth comes from."""
    from matplotlib.figure import Figure  # imported on use: a CLI checks its input before loading matplotlib

    fig = Figure(figsize=(5.5, 5.0))
    ax = fig.subplots()
    for name, box in boxes.items():
        colour, marker, label = METHOD_STYLES[name]
        outline = np.vstack([box.corners_mm(), box.corners_mm()[:1]]) / 1000.0
        ax.plot(outline[:, 0], outline[:, 1], color=colour, marker=marker, label=label, linewidth=1.5)
        front = box.corners_mm()[:2].mean(axis=0) / 1000.0
        ax.plot(*zip(box.centre_mm / 1000.0, front), color=colour, linewidth=0.8, linestyle="--")
    if tyres_mm is not None:
        ax.plot(tyres_mm[:, 0] / 1000.0, tyres_mm[:, 1] / 1000.0, "o", color="tab:cyan", markersize=4, label="tyres")
    ax.set_aspect("equal")
    ax.set_xlabel("X across the road (m)")
    ax.set_ylabel("Y along the road (m)")
    ax.set_title(title, fontsize=9)
    ax.grid(True, linewidth=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    with atomic_path(path) as temporary:
        fig.savefig(temporary, dpi=110, format="png")
    return path
