"""A straight road with painted markers in the paper's world frame, and its rendering by a camera.

Markers are rectangles on the road plane (Z = 0), in mm. Corners are ordered near-left, near-right,
far-right, far-left (near = smaller Y). Dashed lane lines and stop lines have usable corners;
solid edge lines run past the rendered stretch and do not.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.config import check_choice, check_range
from vehloc.geometry.camera import PinholeCamera
from vehloc.synth.raster import fill_polygon_px

WHITE_BGR = (235, 238, 238)
YELLOW_BGR = (40, 190, 225)
MARKER_SUPERSAMPLE = 8
MARKER_COLOURS = ("white", "yellow")


@dataclass(frozen=True)
class RoadMarker:
    """One painted rectangle: an id, its four world corners (mm) and how it may be used."""

    marker_id: str
    corners_mm: np.ndarray
    colour: str = "white"
    has_corners: bool = True


@dataclass(frozen=True)
class RoadLayout:
    """A straight road centred on X = 0, running along +Y from `start_y_mm` to `end_y_mm`."""

    lane_count: int = 2
    lane_width_mm: float = 3660.0
    line_width_mm: float = 150.0
    dash_length_mm: float = 3000.0
    dash_gap_mm: float = 6000.0
    dash_phase_mm: float = 0.0
    start_y_mm: float = 0.0
    end_y_mm: float = 60000.0
    edge_colour: str = "white"
    centre_colour: str = "white"
    stop_line_y_mm: float | None = None
    stop_line_width_mm: float = 400.0
    verge_width_mm: float = 3000.0

    def __post_init__(self) -> None:
        check_range("lane_count", self.lane_count, 1, 12)
        check_range("lane_width_mm", self.lane_width_mm, 0.0, low_open=True)
        check_range("line_width_mm", self.line_width_mm, 0.0, self.lane_width_mm / 2, low_open=True, high_open=True)
        check_range("dash_length_mm", self.dash_length_mm, 0.0, low_open=True)
        check_range("dash_gap_mm", self.dash_gap_mm, 0.0)
        check_range("end_y_mm", self.end_y_mm, self.start_y_mm, low_open=True)
        check_range("stop_line_width_mm", self.stop_line_width_mm, 0.0, low_open=True)
        check_range("verge_width_mm", self.verge_width_mm, 0.0)
        check_choice("edge_colour", self.edge_colour, MARKER_COLOURS)
        check_choice("centre_colour", self.centre_colour, MARKER_COLOURS)

    @property
    def road_width_mm(self) -> float:
        return self.lane_count * self.lane_width_mm

    def markers(self) -> list[RoadMarker]:
        """Every marker of the layout: dashed lane lines, solid edge lines, the optional stop line."""
        half_road = self.road_width_mm / 2
        half_line = self.line_width_mm / 2
        markers = []
        for side, x_mm in (("left", -half_road + half_line), ("right", half_road - half_line)):
            markers.append(
                RoadMarker(
                    f"edge_{side}",
                    _rectangle(x_mm - half_line, x_mm + half_line, self.start_y_mm, self.end_y_mm),
                    self.edge_colour,
                    has_corners=False,
                )
            )
        period = self.dash_length_mm + self.dash_gap_mm
        for lane_line in range(1, self.lane_count):
            x_mm = -half_road + lane_line * self.lane_width_mm
            y_mm = self.start_y_mm + self.dash_phase_mm
            index = 0
            while y_mm + self.dash_length_mm <= self.end_y_mm:
                markers.append(
                    RoadMarker(
                        f"lane{lane_line}_dash{index}",
                        _rectangle(x_mm - half_line, x_mm + half_line, y_mm, y_mm + self.dash_length_mm),
                        self.centre_colour,
                    )
                )
                y_mm += period
                index += 1
        if self.stop_line_y_mm is not None:
            markers.append(
                RoadMarker(
                    "stop_line",
                    _rectangle(
                        -half_road + self.line_width_mm, half_road - self.line_width_mm,
                        self.stop_line_y_mm, self.stop_line_y_mm + self.stop_line_width_mm,
                    ),
                )
            )
        return markers


def _rectangle(x0_mm: float, x1_mm: float, y0_mm: float, y1_mm: float) -> np.ndarray:
    return np.array([[x0_mm, y0_mm], [x1_mm, y0_mm], [x1_mm, y1_mm], [x0_mm, y1_mm]], dtype=float)


def project_road_polygon(camera: PinholeCamera, corners_mm: np.ndarray) -> np.ndarray:
    """Image polygon (M, 2) px of a road-plane polygon (N, 2) mm, clipped to the visible half-space."""
    return camera.project_polygon(np.column_stack([corners_mm, np.zeros(len(corners_mm))]))


def _asphalt_texture(rng: np.random.Generator, shape: tuple[int, int], base_grey: float) -> np.ndarray:
    fine = rng.normal(0.0, 9.0, shape)
    coarse = cv2.resize(rng.normal(0.0, 6.0, (shape[0] // 16 + 1, shape[1] // 16 + 1)), shape[::-1])
    grey = np.clip(base_grey + fine + coarse, 0, 255).astype(np.uint8)
    return cv2.merge([grey, grey, grey])


def render_road(
    camera: PinholeCamera,
    layout: RoadLayout,
    rng: np.random.Generator,
    asphalt_grey: float = 95.0,
    texture_mm_per_px: float = 25.0,
) -> np.ndarray:
    """Render sky, verge, asphalt and markers as the camera sees them (uint8 BGR)."""
    height_px, width_px = camera.height_px, camera.width_px
    rows = np.linspace(0.0, 1.0, height_px)[:, None, None]
    sky = np.array([235, 215, 190], dtype=float) * (1 - rows) + np.array([245, 235, 225], dtype=float) * rows
    image = np.broadcast_to(sky, (height_px, width_px, 3)).astype(np.uint8).copy()

    half_verge = layout.road_width_mm / 2 + layout.verge_width_mm
    ground = np.array(
        [[-half_verge, layout.start_y_mm], [half_verge, layout.start_y_mm],
         [half_verge, layout.end_y_mm], [-half_verge, layout.end_y_mm]]
    )
    fill_polygon_px(image, project_road_polygon(camera, ground), (70, 120, 95))

    half_road = layout.road_width_mm / 2
    texture_w = int(np.ceil(layout.road_width_mm / texture_mm_per_px))
    texture_h = int(np.ceil((layout.end_y_mm - layout.start_y_mm) / texture_mm_per_px))
    texture = _asphalt_texture(rng, (texture_h, texture_w), asphalt_grey)
    texture_to_road = np.array(
        [[texture_mm_per_px, 0.0, -half_road], [0.0, texture_mm_per_px, layout.start_y_mm], [0.0, 0.0, 1.0]]
    )
    texture_to_image = camera.road_to_image().matrix @ texture_to_road
    asphalt = cv2.warpPerspective(texture, texture_to_image, (width_px, height_px), flags=cv2.INTER_LINEAR)
    road_mask = np.zeros((height_px, width_px), np.uint8)
    road = _rectangle(-half_road, half_road, layout.start_y_mm, layout.end_y_mm)
    fill_polygon_px(road_mask, project_road_polygon(camera, road), 255)
    alpha = (road_mask.astype(np.float32) / 255.0)[..., None]
    image = (image * (1 - alpha) + asphalt * alpha).astype(np.uint8)

    for marker in layout.markers():
        colour = YELLOW_BGR if marker.colour == "yellow" else WHITE_BGR
        fill_polygon_px(image, project_road_polygon(camera, marker.corners_mm), colour, MARKER_SUPERSAMPLE)
    return image
