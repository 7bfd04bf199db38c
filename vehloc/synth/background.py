"""Random backgrounds consistent with a camera: sky and horizon, textured ground, a road, clutter."""

from __future__ import annotations

import cv2
import numpy as np

from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.render import fill_world_polygon

_SKIES_BGR = (
    ((235, 200, 150), (250, 235, 215)),  # clear blue
    ((205, 200, 195), (235, 232, 228)),  # overcast
    ((190, 170, 160), (210, 215, 225)),  # hazy
    ((150, 140, 170), (170, 200, 235)),  # dusk
)
_GROUNDS_BGR = ((92, 94, 96), (120, 122, 124), (150, 152, 150), (70, 110, 90), (110, 140, 160), (60, 62, 64))
_MARKINGS_BGR = ((235, 235, 235), (70, 200, 230))


def _smooth_noise(rng: np.random.Generator, height: int, width: int, cells: int) -> np.ndarray:
    """Low-frequency noise in [-1, 1] (H, W), from a coarse random grid upsampled smoothly."""
    coarse = rng.uniform(-1, 1, (cells, max(2, cells * width // max(height, 1)))).astype(np.float32)
    return cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC)


def horizon_mask(camera: PinholeCamera) -> np.ndarray:
    """Boolean (H, W) of the pixels whose rays point below the horizon (they see the ground)."""
    # The world z of the ray through pixel (x, y) is linear in (x, 1) and (y, 1).
    a, b, c = np.linalg.inv(camera.K).T @ camera.R[:, 2]
    xs = np.arange(camera.width_px, dtype=float)[None, :]
    ys = np.arange(camera.height_px, dtype=float)[:, None]
    return a * xs + b * ys + c < 0


def random_background(
    rng: np.random.Generator, camera: PinholeCamera, centre_mm: np.ndarray, road_heading_deg: float
) -> np.ndarray:
    """A BGR uint8 background for ``camera``: ground below the horizon with a road through ``centre_mm``."""
    height, width = camera.height_px, camera.width_px
    ground = horizon_mask(camera)
    rows = np.linspace(0.0, 1.0, height, dtype=np.float32)[:, None, None]

    sky_top, sky_bottom = (np.array(c, np.float32) for c in _SKIES_BGR[rng.integers(len(_SKIES_BGR))])
    image = sky_top * (1 - rows) + sky_bottom * rows
    image = np.broadcast_to(image, (height, width, 3)).copy()
    image += 18.0 * _smooth_noise(rng, height, width, 4)[:, :, None]

    ground_bgr = np.array(_GROUNDS_BGR[rng.integers(len(_GROUNDS_BGR))], np.float32)
    base = ground_bgr * rng.uniform(0.85, 1.15) + rng.uniform(-5, 5, 3)
    ground_image = base + 25.0 * _smooth_noise(rng, height, width, 6)[:, :, None] * rng.uniform(0.3, 1.0)
    ground_image += (rows - 0.5) * rng.uniform(-30, 30)
    ground_image += rng.uniform(2, 9) * rng.standard_normal((height, width, 1), dtype=np.float32)
    if rng.random() < 0.8:
        _draw_road(rng, ground_image, camera, np.asarray(centre_mm, dtype=float), road_heading_deg)

    image[ground] = ground_image[ground]
    horizon_rows = np.flatnonzero(ground.any(axis=1))
    horizon_y = int(horizon_rows[0]) if len(horizon_rows) else height
    for _ in range(int(rng.integers(0, 5))):
        _draw_clutter(rng, image, horizon_y)
    blur = rng.uniform(0.3, 1.5)
    image = cv2.GaussianBlur(image, (0, 0), blur)
    return np.clip(image, 0, 255).astype(np.uint8)


def _road_strip(
    centre_mm: np.ndarray, heading_deg: float, across_mm: tuple[float, float], along_mm: tuple[float, float]
) -> np.ndarray:
    """Corners (4, 3) of a rectangle on the road plane, in coordinates across and along a road."""
    direction = np.radians(heading_deg)
    along = np.array([np.cos(direction), np.sin(direction), 0.0])
    across = np.array([-np.sin(direction), np.cos(direction), 0.0])
    origin = centre_mm * np.array([1.0, 1.0, 0.0])
    corners = ((0, 0), (1, 0), (1, 1), (0, 1))
    return np.array([origin + across * across_mm[i] + along * along_mm[j] for i, j in corners])


def _draw_road(
    rng: np.random.Generator,
    image: np.ndarray,
    camera: PinholeCamera,
    centre_mm: np.ndarray,
    heading_deg: float,
) -> None:
    """Asphalt with solid edge lines and a dashed lane line, running through ``centre_mm``."""
    half_mm, offset_mm, reach_mm = rng.uniform(3500, 7000), rng.uniform(-1500, 1500), 2e5
    asphalt = float(rng.uniform(60, 115))
    road = _road_strip(
        centre_mm, heading_deg, (offset_mm - half_mm, offset_mm + half_mm), (-reach_mm, reach_mm)
    )
    fill_world_polygon(image, camera, road, (asphalt, asphalt, asphalt + rng.uniform(-4, 4)))
    marking = tuple(float(c) for c in _MARKINGS_BGR[rng.integers(len(_MARKINGS_BGR))])
    dash_mm, gap_mm = rng.uniform(2000, 4000), rng.uniform(3000, 9000)
    phase_mm = rng.uniform(0, dash_mm + gap_mm)
    for line_mm in (offset_mm - half_mm + 300, offset_mm + half_mm - 300):
        edge = _road_strip(centre_mm, heading_deg, (line_mm - 75, line_mm + 75), (-reach_mm, reach_mm))
        fill_world_polygon(image, camera, edge, (215.0, 215.0, 215.0))
    lane_mm = offset_mm + rng.choice([-1, 1]) * rng.uniform(1600, 2000)
    for start_mm in np.arange(-12, 13) * (dash_mm + gap_mm) + phase_mm:
        dash = _road_strip(
            centre_mm, heading_deg, (lane_mm - 75, lane_mm + 75), (start_mm, start_mm + dash_mm)
        )
        fill_world_polygon(image, camera, dash, marking)


def _draw_clutter(rng: np.random.Generator, image: np.ndarray, horizon_y: int) -> None:
    """A building or tree standing on the horizon, or a muted blob on the ground or sky."""
    height, width = image.shape[:2]
    grey = rng.uniform(50, 190)
    colour = tuple(float(np.clip(grey + c, 0, 255)) for c in rng.uniform(-25, 25, 3))
    overlay = image.copy()
    if 0 < horizon_y < height and rng.random() < 0.7:
        x0 = int(rng.integers(-20, width))
        w = int(rng.integers(15, max(16, width // 3)))
        top = int(horizon_y - rng.integers(5, max(6, horizon_y + 1)))
        if rng.random() < 0.5:
            cv2.rectangle(overlay, (x0, top), (x0 + w, horizon_y + 2), colour, -1)
        else:
            cv2.ellipse(
                overlay, (x0 + w // 2, top + w // 2), (w // 2, w // 2), 0, 0, 360, colour, -1, cv2.LINE_AA
            )
            cv2.rectangle(
                overlay,
                (x0 + w // 2 - 2, top + w // 2),
                (x0 + w // 2 + 2, horizon_y + 2),
                (40.0, 50.0, 60.0),
                -1,
            )
        alpha = rng.uniform(0.6, 0.95)
    else:
        centre = rng.uniform([0, 0], [width, height])
        radius = rng.uniform(8, min(width, height) / 3)
        angles = np.sort(rng.uniform(0, 2 * np.pi, int(rng.integers(3, 8))))
        points = centre + radius * np.column_stack([np.cos(angles), np.sin(angles)])
        cv2.fillPoly(overlay, [points.astype(np.int32)], colour, cv2.LINE_AA)
        alpha = rng.uniform(0.3, 0.7)
    image[:] = image * (1 - alpha) + overlay * alpha
