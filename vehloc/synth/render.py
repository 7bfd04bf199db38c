"""Rasterise catalog cars through a `PinholeCamera`: painter's algorithm, Lambert shading, soft shadow.

The car is drawn at ``supersample`` times the image resolution and averaged down, which anti-aliases
the edges and gives each pixel's car coverage; the car's box is the tight box of the pixels it
covers at least half. Only the region the car and its shadow can reach is drawn and blended (the
projected vertices' box, and the shadow polygons' box grown by the blur kernel), so a car costs in
proportion to its size in the image, not to the frame's.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from vehloc.data.boxes import Box
from vehloc.geometry.camera import NEAR_PLANE_MM, PinholeCamera
from vehloc.synth.body import Material, Mesh, build_car_mesh, plate_corners_car_mm
from vehloc.synth.catalog import RGB, CarModel
from vehloc.synth.raster import SUBPIXEL_SHIFT, fill_polygon_px

HEADING_CONVENTION = "heading_deg: angle from world +X to the car's front, counter-clockwise seen from above"
"""A car pose (x_mm, y_mm, heading_deg) puts the car-frame origin (centre of the footprint on the ground)
at world (x_mm, y_mm, 0) and turns the car's front (+x of the car frame) from world +X by heading_deg,
counter-clockwise seen from above (towards +Y); the car's +y (its left) follows, and +z stays up."""


@dataclass(frozen=True)
class CarPose:
    """Where a car stands on the road plane; see `HEADING_CONVENTION`."""

    x_mm: float
    y_mm: float
    heading_deg: float

    @property
    def rotation(self) -> np.ndarray:
        """Car-frame -> world rotation (3x3)."""
        c, s = np.cos(np.radians(self.heading_deg)), np.sin(np.radians(self.heading_deg))
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def car_to_world(self, points_mm: np.ndarray) -> np.ndarray:
        """Car-frame points (N, 3) -> world points (N, 3), mm."""
        return np.asarray(points_mm, dtype=float) @ self.rotation.T + np.array([self.x_mm, self.y_mm, 0.0])


@dataclass(frozen=True)
class Lighting:
    """A distant light: unit ``direction`` towards it (world), and ambient and direct strengths."""

    direction: tuple[float, float, float] = (0.4, -0.5, 0.77)
    ambient: float = 0.45
    diffuse: float = 0.65

    @staticmethod
    def from_angles(azimuth_deg: float, elevation_deg: float, ambient: float, diffuse: float) -> Lighting:
        """Light from ``azimuth_deg`` (from +X, counter-clockwise) and ``elevation_deg`` above the road."""
        az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
        direction = (np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el))
        return Lighting(tuple(float(v) for v in direction), ambient, diffuse)


@dataclass(frozen=True)
class _Finish:
    rgb: RGB
    ambient: float = 1.0
    diffuse: float = 1.0
    specular: float = 0.0
    emissive: float = 0.0


_FINISHES: dict[Material, _Finish] = {
    Material.GLASS: _Finish((26, 34, 44), specular=0.55),
    Material.TRIM: _Finish((30, 30, 32), specular=0.1),
    Material.CHROME: _Finish((196, 198, 204), specular=0.7),
    Material.UNDERBODY: _Finish((16, 16, 16), ambient=0.8, diffuse=0.3),
    Material.TYRE: _Finish((26, 26, 28), diffuse=0.6),
    Material.HUB_DARK: _Finish((28, 28, 30)),
    Material.HEADLIGHT: _Finish((196, 206, 216), specular=0.5, emissive=0.35),
    Material.LAMP_ACCENT: _Finish((248, 248, 252), emissive=0.8),
    Material.TAILLIGHT: _Finish((190, 20, 26), specular=0.4, emissive=0.55),
    Material.REVERSE_LIGHT: _Finish((226, 226, 230), emissive=0.5),
    Material.PLATE: _Finish((236, 236, 228), emissive=0.45),
    Material.PLATE_INK: _Finish((22, 24, 32)),
    Material.BED: _Finish((34, 34, 36)),
}


@dataclass(frozen=True, eq=False)
class CarRender:
    """A rendered car over its background, with its ground truth in the image.

    ``coverage``: fraction of each pixel covered by the car (H, W). ``box``: tight box of the pixels
    covered at least half, or None when none is.
    Tyre contact points are ordered front-left, front-right, rear-left, rear-right; footprint corners
    front-left, front-right, rear-right, rear-left (world mm, and pixels). ``plates``: the front and rear
    licence plates (corners in world mm and pixels, and whether the plate faces the camera).
    """

    image_bgr: np.ndarray
    coverage: np.ndarray
    box: Box | None
    tyre_contacts_mm: np.ndarray
    tyre_contacts_px: np.ndarray
    footprint_corners_mm: np.ndarray
    footprint_corners_px: np.ndarray
    plates: dict[str, PlateTruth]

    @property
    def mask(self) -> np.ndarray:
        return self.coverage >= 0.5


@dataclass(frozen=True, eq=False)
class PlateTruth:
    """A licence plate's corners (4, 3) world mm and (4, 2) px, and whether its face is turned to the camera."""

    corners_mm: np.ndarray
    corners_px: np.ndarray
    faces_camera: bool

    @property
    def centre_mm(self) -> np.ndarray:
        return self.corners_mm.mean(axis=0)


def plates_seen(model: CarModel, pose: CarPose, camera: PinholeCamera) -> dict[str, PlateTruth]:
    """The model's front and rear plates at `pose`, as `camera` sees them."""
    plates = {}
    for end, corners_car in plate_corners_car_mm(model).items():
        corners = pose.car_to_world(corners_car)
        outward = pose.rotation @ np.array([1.0 if end == "front" else -1.0, 0.0, 0.0])
        faces = float(outward @ (camera.centre_mm - corners.mean(axis=0))) > 0
        plates[end] = PlateTruth(corners, camera.project(corners), faces)
    return plates


def tyre_contacts_car_mm(model: CarModel) -> np.ndarray:
    """Tyre contact points in the car frame: front-left, front-right, rear-left, rear-right."""
    f, r = model.front_axle_x_mm, model.rear_axle_x_mm
    tf, tr = model.track_front_mm / 2, model.track_rear_mm / 2
    return np.array([[f, tf, 0.0], [f, -tf, 0.0], [r, tr, 0.0], [r, -tr, 0.0]])


def footprint_car_mm(model: CarModel) -> np.ndarray:
    """Footprint corners in the car frame: front-left, front-right, rear-right, rear-left."""
    hl, hw = model.length_mm / 2, model.width_mm / 2
    return np.array([[hl, hw, 0.0], [hl, -hw, 0.0], [-hl, -hw, 0.0], [-hl, hw, 0.0]])


def fill_world_polygon(
    image: np.ndarray, camera: PinholeCamera, polygon_mm: np.ndarray, colour: tuple[float, ...]
) -> None:
    """Fill a world polygon (N, 3) into ``image`` (anti-aliased), clipped to the camera's near plane."""
    fill_polygon_px(image, camera.project_polygon(polygon_mm), colour)


def _face_colours(
    mesh: Mesh,
    normals: np.ndarray,
    centroids: np.ndarray,
    camera_mm: np.ndarray,
    lighting: Lighting,
    body_rgb: RGB,
    model: CarModel,
) -> np.ndarray:
    """Shaded BGR colour (F, 3) of every face."""
    light = np.asarray(lighting.direction, dtype=float)
    light /= np.linalg.norm(light)
    view = camera_mm - centroids
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    half = view + light
    half /= np.linalg.norm(half, axis=1, keepdims=True)
    lambert = np.clip(normals @ light, 0.0, None)
    highlight = np.clip(np.sum(normals * half, axis=1), 0.0, None) ** 24
    sky = 0.8 + 0.2 * normals[:, 2]
    finishes = dict(_FINISHES)
    finishes[Material.BODY] = _Finish(body_rgb, specular=0.35)
    finishes[Material.MIRROR] = finishes[Material.BODY]
    finishes[Material.GRILLE] = _Finish(model.details.grille_rgb, specular=0.1)
    finishes[Material.HUB] = _Finish(model.details.hub_rgb, specular=0.4)
    by_value = [finishes[material] for material in Material]
    table_rgb = np.array([f.rgb for f in by_value], dtype=float)
    table_params = np.array([(f.ambient, f.diffuse, f.specular, f.emissive) for f in by_value])
    rgb = table_rgb[mesh.materials]
    ambient, diffuse, specular, emissive = table_params[mesh.materials].T
    shade = lighting.ambient * ambient * sky + lighting.diffuse * diffuse * lambert
    lit = (
        rgb * (emissive + (1 - emissive) * shade)[:, None]
        + (255.0 * lighting.diffuse * specular * highlight)[:, None]
    )
    return np.clip(lit, 0, 255)[:, ::-1]


CAR_PAD_PX = 2
"""Margin around the car's projected vertices that its supersampled layer covers (the fill and the area
average reach at most a pixel past them)."""
SHADOW_STRENGTH = 0.55
"""How much of the road's light a car's cast shadow takes off at its darkest (its core region's weight)."""


def _pixel_bounds(points_px: np.ndarray, pad_px: int, width_px: int, height_px: int) -> Box:
    """The pixels within ``pad_px`` of the points' bounding box, clipped to the image (possibly empty)."""
    x0, y0 = np.floor(points_px.min(axis=0)).astype(int) - pad_px
    x1, y1 = np.ceil(points_px.max(axis=0)).astype(int) + pad_px + 1
    return Box(int(x0), int(y0), int(x1), int(y1)).clipped(width_px, height_px)


def _slices(box: Box, region: Box) -> tuple[slice, slice]:
    """Row and column slices of ``box`` inside an array that holds ``region``."""
    return slice(box.y0 - region.y0, box.y1 - region.y0), slice(box.x0 - region.x0, box.x1 - region.x0)


def _gaussian_ksize(sigma: float) -> int:
    """The kernel size OpenCV picks for a float image and ``sigma`` (ksize (0, 0)), made explicit so that
    the region a blurred shadow reaches is known."""
    return int(round(8.0 * sigma + 1.0)) | 1


def _shadows(
    camera: PinholeCamera, model: CarModel, pose: CarPose, lighting: Lighting, strength: float
) -> list[tuple[Box, float, np.ndarray]]:
    """The road's darkening under the car, as (region, weight, blurred shadow of the region): a wide soft
    shadow offset away from the light, and a contact shadow. Each region is the shadow polygon's pixels
    grown by the blur kernel's radius, so the blur outside it is zero as on a full frame."""
    height, width = camera.height_px, camera.width_px
    light = np.asarray(lighting.direction, dtype=float)
    away_mm = -light[:2] / max(np.linalg.norm(light[:2]), 1e-9) * min(0.35 / max(light[2], 0.25), 1.2) * 400.0
    footprint = footprint_car_mm(model)
    shadows = []
    for scale, shift, blur_frac, weight in ((1.08, 1.0, 0.05, strength), (0.96, 0.0, 0.02, strength * 0.7)):
        corners = pose.car_to_world(footprint * np.array([scale, scale, 0.0]))
        corners[:, :2] += away_mm * shift
        polygon_px = camera.project_polygon(corners)
        if len(polygon_px) < 3:
            continue
        near = _pixel_bounds(polygon_px, 2, width, height)
        if near.is_empty:
            continue
        filled = np.zeros((near.height_px, near.width_px), np.float32)
        fill_polygon_px(filled, polygon_px - [near.x0, near.y0], (1.0,))
        tight = _shifted(Box.tight(filled > 0), near)
        if tight is None:
            continue
        sigma = max(1.0, blur_frac * max(tight.width_px - 1, tight.height_px - 1))
        ksize = _gaussian_ksize(sigma)
        reach = ksize // 2 + 1
        region = tight.grown(reach, width, height)
        shadow = np.zeros((region.height_px, region.width_px), np.float32)
        shadow[_slices(tight, region)] = filled[_slices(tight, near)]
        shadows.append((region, weight, cv2.GaussianBlur(shadow, (ksize, ksize), sigma)))
    return shadows


def shadow_darkening(camera: PinholeCamera, model: CarModel, pose: CarPose, lighting: Lighting,
                     strength: float = SHADOW_STRENGTH) -> np.ndarray:
    """The share of the road's light the car's shadows take off at each pixel (H, W, in [0, 1]), as `render_car`
    darkens the road under the same light and `strength`: the truth of where its shadow falls."""
    darkening = np.zeros((camera.height_px, camera.width_px), np.float32)
    frame = Box(0, 0, camera.width_px, camera.height_px)
    for region, weight, shadow in _shadows(camera, model, pose, lighting, strength):
        cells = darkening[_slices(region, frame)]
        cells[:] = 1.0 - (1.0 - cells) * (1.0 - weight * shadow)
    return darkening


def _shifted(box: Box | None, region: Box) -> Box | None:
    """A box found inside an array that holds ``region``, in image pixels."""
    if box is None:
        return None
    return Box(box.x0 + region.x0, box.y0 + region.y0, box.x1 + region.x0, box.y1 + region.y0)


@dataclass(frozen=True, eq=False)
class _ProjectedFaces:
    """A car's mesh seen by a camera: its visible faces in painter's ``order`` (far to near), every vertex's
    pixel position and every face's shaded BGR colour."""

    mesh: Mesh
    order: np.ndarray
    pixels: np.ndarray
    colours: np.ndarray


def _projected_faces(
    model: CarModel, body_rgb: RGB, pose: CarPose, camera: PinholeCamera, lighting: Lighting, plates: bool = True
) -> _ProjectedFaces:
    """Cull, sort, project and shade the model's faces; ValueError when part of the car is behind the
    camera's near plane."""
    mesh = build_car_mesh(model, plates)
    vertices = pose.car_to_world(mesh.vertices_mm)
    centroids = pose.car_to_world(mesh.centroids_mm)
    normals = mesh.normals @ pose.rotation.T
    camera_mm = camera.centre_mm

    facing = np.sum(normals * (camera_mm - centroids), axis=1) > 0
    visible = facing[mesh.groups]
    depth = np.linalg.norm(centroids[mesh.groups] - camera_mm, axis=1)
    order = np.lexsort((mesh.layers, mesh.groups, -depth))
    order = order[visible[order]]

    vertices_cam = camera.to_camera(vertices)
    if vertices_cam[:, 2].min() < NEAR_PLANE_MM:
        raise ValueError(f"{model.name} at {pose} is not entirely in front of the camera")
    colours = _face_colours(mesh, normals, centroids, camera_mm, lighting, body_rgb, model)
    return _ProjectedFaces(mesh, order, camera.project_camera(vertices_cam), colours)


def _rasterise(faces: _ProjectedFaces, region: Box, supersample: int) -> tuple[np.ndarray, np.ndarray]:
    """The faces drawn ``supersample`` times finer over ``region`` and averaged down: the car's
    premultiplied BGR (h, w, 3) and its coverage (h, w) of the region's pixels. The fine grid is that of
    the whole image shifted by whole pixels, so the region comes out as on a full-frame layer."""
    scale = supersample << SUBPIXEL_SHIFT
    points = np.round(((faces.pixels + 0.5) * supersample - 0.5) * (1 << SUBPIXEL_SHIFT))
    points = (points - np.array([region.x0, region.y0]) * scale).astype(np.int32)
    colours4 = np.column_stack([faces.colours, np.full(len(faces.colours), 255.0)]).tolist()
    layer = np.zeros((region.height_px * supersample, region.width_px * supersample, 4), np.uint8)
    offsets = faces.mesh.offsets
    for face in faces.order.tolist():
        cv2.fillPoly(layer, [points[offsets[face] : offsets[face + 1]]], colours4[face], cv2.LINE_8, SUBPIXEL_SHIFT)
    small = cv2.resize(layer, (region.width_px, region.height_px), interpolation=cv2.INTER_AREA).astype(np.float32)
    return small[:, :, :3], small[:, :, 3] / 255.0


def _union(boxes: list[Box]) -> Box | None:
    """The smallest box holding every box of the list; None for an empty list."""
    if not boxes:
        return None
    return Box(min(b.x0 for b in boxes), min(b.y0 for b in boxes), max(b.x1 for b in boxes), max(b.y1 for b in boxes))


def render_car(
    model: CarModel,
    body_rgb: RGB,
    pose: CarPose,
    camera: PinholeCamera,
    background_bgr: np.ndarray,
    lighting: Lighting = Lighting(),
    shadow_strength: float = SHADOW_STRENGTH,
    supersample: int = 3,
    plates: bool = True,
) -> CarRender:
    """Render one car over a background image (H, W, 3 uint8, the camera's size), with or without its licence
    plates (`plates` of the result is empty without)."""
    height, width = camera.height_px, camera.width_px
    if background_bgr.shape != (height, width, 3):
        raise ValueError(
            f"background shape {background_bgr.shape} does not match the camera's {(height, width, 3)}"
        )
    faces = _projected_faces(model, body_rgb, pose, camera, lighting, plates)

    frame = Box(0, 0, width, height)
    shadows = _shadows(camera, model, pose, lighting, shadow_strength) if shadow_strength > 0 else []
    car_region = _pixel_bounds(faces.pixels, CAR_PAD_PX, width, height)
    region = _union([box for box, _, _ in shadows] + ([] if car_region.is_empty else [car_region]))
    image_bgr = background_bgr.copy()
    coverage = np.zeros((height, width), np.float32)
    box = None
    if region is not None:
        patch = background_bgr[_slices(region, frame)].astype(np.float32)
        for shadow_region, weight, shadow in shadows:
            patch[_slices(shadow_region, region)] *= (1.0 - weight * shadow)[:, :, None]
        if not car_region.is_empty:
            car_bgr, car_coverage = _rasterise(faces, car_region, supersample)
            car_patch = patch[_slices(car_region, region)]
            car_patch[:] = car_patch * (1.0 - car_coverage[:, :, None]) + car_bgr
            coverage[_slices(car_region, frame)] = car_coverage
            box = _shifted(Box.tight(car_coverage >= 0.5), car_region)
        image_bgr[_slices(region, frame)] = np.clip(np.round(patch), 0, 255).astype(np.uint8)

    contacts_mm = pose.car_to_world(tyre_contacts_car_mm(model))
    corners_mm = pose.car_to_world(footprint_car_mm(model))
    return CarRender(
        image_bgr=image_bgr,
        coverage=coverage,
        box=box,
        tyre_contacts_mm=contacts_mm,
        tyre_contacts_px=camera.project(contacts_mm),
        footprint_corners_mm=corners_mm,
        footprint_corners_px=camera.project(corners_mm),
        plates=plates_seen(model, pose, camera) if plates else {},
    )
