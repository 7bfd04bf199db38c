"""Parametric 3D polygon mesh of a catalog car.

Car frame (mm): origin at the centre of the footprint on the ground, +x forward (the car's front),
+y to the car's left, +z up. The body is lofted from cross-sections along x, so the bonnet,
windscreen, roof, rear window and boot come out of the `BodyShape` parameters; lights, grille and
licence plates are flat decals on the front and rear faces, drawn just after the face they lie on.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum
from functools import cache

import numpy as np

from vehloc.data.shapes import VehicleShape
from vehloc.synth.catalog import CATALOG, CarModel

PLATE_SIZE_MM = (440.0, 140.0)
"""Licence plate width and height (the Chinese standard plate)."""

ARCH_GAP_MM = 35.0
"""Radial gap between a tyre and its wheel arch."""

WHEEL_SEGMENTS = 20
MAX_STATION_GAP_MM = 220.0


class Material(IntEnum):
    """What a face is made of; the renderer maps it to a colour and shading."""

    BODY = 0
    MIRROR = 1
    GLASS = 2
    TRIM = 3
    CHROME = 4
    UNDERBODY = 5
    TYRE = 6
    HUB = 7
    HUB_DARK = 8
    HEADLIGHT = 9
    LAMP_ACCENT = 10
    TAILLIGHT = 11
    REVERSE_LIGHT = 12
    PLATE = 13
    PLATE_INK = 14
    GRILLE = 15
    BED = 16


@dataclass(frozen=True, eq=False)
class Mesh:
    """Flat-shaded polygons in the car frame.

    Face ``i`` has the vertices ``vertices_mm[offsets[i]:offsets[i + 1]]``, counter-clockwise seen from
    outside, its outward unit ``normals[i]``, ``materials[i]``, and ``groups[i]``: the face it is painted
    on (itself for surfaces); ``layers[i]`` orders the decals of one group (0 for the surface).
    """

    vertices_mm: np.ndarray
    offsets: np.ndarray
    normals: np.ndarray
    centroids_mm: np.ndarray
    materials: np.ndarray
    groups: np.ndarray
    layers: np.ndarray

    @property
    def num_faces(self) -> int:
        return len(self.materials)

    def face(self, index: int) -> np.ndarray:
        return self.vertices_mm[self.offsets[index] : self.offsets[index + 1]]


def _area_vector(points: np.ndarray) -> np.ndarray:
    """Area times unit normal of a planar polygon (Newell), the normal by the right-hand rule."""
    return 0.5 * np.cross(points, np.roll(points, -1, axis=0)).sum(axis=0)


class _MeshBuilder:
    def __init__(self) -> None:
        self.polygons: list[np.ndarray] = []
        self.normals: list[np.ndarray] = []
        self.materials: list[int] = []
        self.groups: list[int] = []
        self.layers: list[int] = []

    def surface(
        self, points: np.ndarray, material: Material, outward: np.ndarray | None = None
    ) -> int | None:
        """Add a surface polygon; flip it to face ``outward`` when given. Degenerate polygons are dropped."""
        points = _dedupe(np.asarray(points, dtype=float))
        if len(points) < 3:
            return None
        area = _area_vector(points)
        norm = np.linalg.norm(area)
        if norm < 1.0:
            return None
        if outward is not None and area @ outward < 0:
            points, area = points[::-1], -area
        index = len(self.polygons)
        self._append(points, area / norm, material, index, 0)
        return index

    def decal(self, parent: int, points: np.ndarray, material: Material, layer: int) -> None:
        """Add a flat decal on the parent face (drawn right after it, when it is visible)."""
        normal = self.normals[parent]
        points = np.asarray(points, dtype=float)
        if _area_vector(points) @ normal < 0:
            points = points[::-1]
        self._append(points, normal, material, parent, layer)

    def _append(
        self, points: np.ndarray, normal: np.ndarray, material: Material, group: int, layer: int
    ) -> None:
        self.polygons.append(points)
        self.normals.append(normal)
        self.materials.append(int(material))
        self.groups.append(group)
        self.layers.append(layer)

    def build(self) -> Mesh:
        counts = np.array([len(p) for p in self.polygons])
        arrays = dict(
            vertices_mm=np.concatenate(self.polygons),
            offsets=np.concatenate([[0], np.cumsum(counts)]),
            normals=np.array(self.normals),
            centroids_mm=np.array([p.mean(axis=0) for p in self.polygons]),
            materials=np.array(self.materials),
            groups=np.array(self.groups),
            layers=np.array(self.layers),
        )
        for array in arrays.values():
            array.setflags(write=False)
        return Mesh(**arrays)


def _dedupe(points: np.ndarray) -> np.ndarray:
    """Drop consecutive (and wrap-around) duplicate vertices."""
    keep = np.linalg.norm(points - np.roll(points, 1, axis=0), axis=1) > 1e-6
    return points[keep] if keep.any() else points[:1]


class _Profile:
    """Side profile, beltline, plan width and underside of the body as functions of x (car frame)."""

    def __init__(self, model: CarModel) -> None:
        s = model.shape
        self.model = model
        half_length = model.length_mm / 2
        self.x_front, self.x_rear = half_length, -half_length
        self.x_cowl = model.cabin_front_x_mm
        self.x_roof_front = self.x_cowl - s.windscreen_run_mm
        self.x_roof_rear = self.x_roof_front - s.roof_length_mm
        self.x_deck = model.cabin_rear_x_mm
        self.key_x = np.array(
            [self.x_rear, self.x_deck, self.x_roof_rear, self.x_roof_front, self.x_cowl, self.x_front]
        )
        self.key_z = np.array(
            [
                s.tail_height_mm,
                s.deck_height_mm,
                model.height_mm,
                model.height_mm,
                s.cowl_height_mm,
                s.nose_height_mm,
            ]
        )
        self.smooth_mm = min(120.0, s.roof_length_mm / 4)

    def top(self, x: np.ndarray) -> np.ndarray:
        """Height of the top outline, with its corners rounded."""
        offsets = np.linspace(-self.smooth_mm, self.smooth_mm, 9)
        samples = np.interp(np.asarray(x)[..., None] + offsets, self.key_x, self.key_z)
        return samples.mean(axis=-1)

    def belt(self, x: np.ndarray) -> np.ndarray:
        """Height of the beltline (shoulder); equals the top outside the cabin."""
        s = self.model.shape
        belt = np.interp(x, [self.x_deck, self.x_cowl], [s.deck_height_mm, s.cowl_height_mm])
        return np.minimum(belt, self.top(x))

    def half_width(self, x: np.ndarray) -> np.ndarray:
        """Half-width in plan, rounding into the front and rear faces over the corner length."""
        s = self.model.shape
        corner = s.corner_length_mm
        front = np.clip((np.asarray(x) - (self.x_front - corner)) / corner, 0, 1)
        rear = np.clip(((self.x_rear + corner) - np.asarray(x)) / corner, 0, 1)
        taper = 1 - (1 - s.nose_width_frac) * front**2 - (1 - s.tail_width_frac) * rear**2
        return self.model.width_mm / 2 * taper

    def underside(self, x: np.ndarray) -> np.ndarray:
        """Underside height outside the wheel arches: the clearance, lifting towards the bumpers."""
        s = self.model.shape
        corner = s.corner_length_mm
        end = np.maximum(
            np.clip((np.asarray(x) - (self.x_front - corner)) / corner, 0, 1),
            np.clip(((self.x_rear + corner) - np.asarray(x)) / corner, 0, 1),
        )
        return s.ground_clearance_mm + 70.0 * end**2


def _stations(model: CarModel, profile: _Profile) -> tuple[np.ndarray, np.ndarray]:
    """Station positions (front to rear) and their underside heights, with wheel-arch cut-outs.

    Each arch edge gets two stations 1 micrometre apart, outside and inside the arch, so that the loft
    closes the arch with a vertical face.
    """
    s = model.shape
    corner = s.corner_length_mm
    arch_radius = s.wheel_radius_mm + ARCH_GAP_MM
    axles = (model.front_axle_x_mm, model.rear_axle_x_mm)
    ends = [profile.x_front - corner * f for f in (0, 0.06, 0.2, 0.4, 0.7, 1.0)]
    ends += [profile.x_rear + corner * f for f in (0, 0.06, 0.2, 0.4, 0.7, 1.0)]
    keys = [k + d for k in profile.key_x[1:-1] for d in (-profile.smooth_mm, 0.0, profile.smooth_mm)]
    glass_front, glass_rear, pillars = _side_glass(model, profile)
    arches = [a + arch_radius * np.cos(t) for a in axles for t in np.linspace(0, np.pi, 11)]
    grid = sorted(set(np.round(ends + keys + [glass_front, glass_rear] + [e for p in pillars for e in p], 3)))
    grid = sorted(set(grid) | set(arches), reverse=True)
    xs = [grid[0]]
    for x in grid[1:]:
        gap = xs[-1] - x
        steps = int(np.ceil(gap / MAX_STATION_GAP_MM))
        xs += list(xs[-1] - gap * np.arange(1, steps + 1) / steps)
    xs_all = np.array(xs + [a + side * (arch_radius + 1e-3) for a in axles for side in (-1, 1)])
    bottoms = profile.underside(xs_all)
    for axle in axles:
        inside = np.abs(xs_all - axle) <= arch_radius
        arch_z = s.wheel_radius_mm + np.sqrt(np.clip(arch_radius**2 - (xs_all - axle) ** 2, 0, None))
        bottoms = np.where(inside, np.maximum(bottoms, arch_z), bottoms)
    order = np.argsort(-xs_all, kind="stable")
    return xs_all[order], bottoms[order]


def _side_glass(model: CarModel, profile: _Profile) -> tuple[float, float, list[tuple[float, float]]]:
    """Front and rear x of the side glass and the (rear, front) x of the pillars between windows."""
    s = model.shape
    glass_front = profile.x_cowl - 0.3 * s.windscreen_run_mm
    glass_rear = profile.x_deck + 0.25 * s.rear_window_run_mm + 100.0
    length = glass_front - glass_rear
    pillars = [
        (glass_front - f * length - 45.0, glass_front - f * length + 45.0)
        for f in model.details.window_splits
    ]
    return glass_front, glass_rear, pillars


def _rings(model: CarModel, profile: _Profile, xs: np.ndarray, bottoms: np.ndarray) -> np.ndarray:
    """Cross-sections (S, 10, 3): bottom, widest, shoulder, window top and roof edge, right then left."""
    s = model.shape
    top = profile.top(xs)
    shoulder = profile.belt(xs)
    half = profile.half_width(xs)
    greenhouse = top - shoulder
    max_greenhouse = model.height_mm - min(s.cowl_height_mm, s.deck_height_mm)
    shoulder_half = half - 30.0
    inset = (1 - s.tumblehome) * shoulder_half * np.clip(greenhouse / max_greenhouse, 0, 1)
    window_top = shoulder + 0.82 * greenhouse
    widest_z = np.maximum(
        bottoms + 30.0, s.ground_clearance_mm + 0.45 * (s.cowl_height_mm - s.ground_clearance_mm)
    )
    widest_z = np.minimum(widest_z, shoulder - 10.0)
    right = [
        (half - 70.0, bottoms),
        (half, widest_z),
        (shoulder_half, shoulder),
        (shoulder_half - 0.82 * inset, window_top),
        (shoulder_half - inset, top),
    ]
    ring_y = [-y for y, _ in right] + [y for y, _ in reversed(right)]
    ring_z = [z for _, z in right] + [z for _, z in reversed(right)]
    rings = np.empty((len(xs), 10, 3))
    rings[:, :, 0] = xs[:, None]
    rings[:, :, 1] = np.stack(ring_y, axis=1)
    rings[:, :, 2] = np.stack(ring_z, axis=1)
    return rings


def _segment_material(model: CarModel, profile: _Profile, segment: int, x_mid: float) -> Material:
    """Material of the loft face on ring segment ``segment`` (vertex k to k+1) between two stations."""
    d = model.details
    pillar = Material.BODY if d.pillar == "body" else Material.TRIM
    if segment == 9:
        return Material.UNDERBODY
    if segment in (0, 8):
        return Material.TRIM if d.lower_cladding else Material.BODY
    if segment in (1, 7, 3, 5):
        return Material.BODY
    if segment in (2, 6):
        glass_front, glass_rear, pillars = _side_glass(model, profile)
        in_glass = glass_rear < x_mid < glass_front and not any(a < x_mid < b for a, b in pillars)
        return Material.GLASS if in_glass else pillar
    if profile.x_roof_front < x_mid < profile.x_cowl or profile.x_deck < x_mid < profile.x_roof_rear:
        return Material.GLASS
    if model.shape.cargo_bed and x_mid < profile.x_deck - 40.0:
        return Material.BED
    return Material.BODY


def _loft(builder: _MeshBuilder, model: CarModel, profile: _Profile, rings: np.ndarray) -> tuple[int, int]:
    """Add the lofted body; returns the indices of the front and rear faces."""
    for i in range(len(rings) - 1):
        x_mid = (rings[i, 0, 0] + rings[i + 1, 0, 0]) / 2
        for k in range(10):
            k1 = (k + 1) % 10
            # Stations run front to rear and rings right over the roof to left: this order faces outward.
            quad = np.array([rings[i, k], rings[i, k1], rings[i + 1, k1], rings[i + 1, k]])
            builder.surface(quad, _segment_material(model, profile, k, x_mid))
    front = builder.surface(rings[0], Material.BODY, np.array([1.0, 0.0, 0.0]))
    rear = builder.surface(rings[-1], Material.BODY, np.array([-1.0, 0.0, 0.0]))
    assert front is not None and rear is not None
    return front, rear


def _circle(centre: tuple[float, float], radius: tuple[float, float], n: int = 16) -> np.ndarray:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([centre[0] + radius[0] * np.cos(angles), centre[1] + radius[1] * np.sin(angles)])


def _rounded_rect(y0: float, y1: float, z0: float, z1: float, r: float, n: int = 4) -> np.ndarray:
    r = min(r, (y1 - y0) / 2, (z1 - z0) / 2)
    points = []
    for cy, cz, start in (
        (y1 - r, z1 - r, 0.0),
        (y0 + r, z1 - r, 90.0),
        (y0 + r, z0 + r, 180.0),
        (y1 - r, z0 + r, 270.0),
    ):
        for a in np.radians(np.linspace(start, start + 90.0, n)):
            points.append((cy + r * np.cos(a), cz + r * np.sin(a)))
    return np.array(points)


def _rect(y0: float, y1: float, z0: float, z1: float) -> np.ndarray:
    return np.array([(y0, z0), (y1, z0), (y1, z1), (y0, z1)])


@dataclass(frozen=True)
class _CapFrame:
    """A front or rear face: x of its plane, usable half-width and height range (mm)."""

    x: float
    half: float
    z0: float
    z1: float

    def uv(self, points: Sequence[tuple[float, float]] | np.ndarray) -> np.ndarray:
        """(u, v) in [-1, 1] x [0, 1] of the face -> (y, z) mm."""
        p = np.asarray(points, dtype=float)
        return np.column_stack([p[:, 0] * self.half, self.z0 + p[:, 1] * (self.z1 - self.z0)])

    def v(self, v: float) -> float:
        return self.z0 + v * (self.z1 - self.z0)

    def to_3d(self, yz: np.ndarray) -> np.ndarray:
        return np.column_stack([np.full(len(yz), self.x), yz[:, 0], yz[:, 1]])


def _both_sides(yz: np.ndarray) -> list[np.ndarray]:
    return [yz, yz * np.array([-1.0, 1.0])]


def _plate(cap: _CapFrame, z_centre: float) -> list[tuple[np.ndarray, Material, int]]:
    """Licence plate: dark border, light plate and seven dark characters."""
    w, h = PLATE_SIZE_MM
    decals = [
        (_rect(-w / 2, w / 2, z_centre - h / 2, z_centre + h / 2), Material.PLATE_INK, 1),
        (_rect(-w / 2 + 10, w / 2 - 10, z_centre - h / 2 + 10, z_centre + h / 2 - 10), Material.PLATE, 2),
    ]
    char_w, gap = 45.0, 12.0
    start = -(7 * char_w + 6 * gap) / 2
    for i in range(7):
        y0 = start + i * (char_w + gap) + (10.0 if i >= 2 else 0.0) - 5.0
        decals.append((_rect(y0, y0 + char_w, z_centre - 45, z_centre + 45), Material.PLATE_INK, 3))
    return decals


def _headlights(cap: _CapFrame, style: str) -> list[tuple[np.ndarray, Material, int]]:
    decals: list[tuple[np.ndarray, Material, int]] = []
    if style == "twin_round":
        housing = cap.uv([(0.48, 0.66), (0.95, 0.72), (0.95, 0.95), (0.50, 0.93)])
        rings = [_circle((cap.half * u, cap.v(0.82)), (55.0, 55.0)) for u in (0.62, 0.83)]
        inner = [_circle((cap.half * u, cap.v(0.82)), (38.0, 38.0)) for u in (0.62, 0.83)]
        parts = [(housing, Material.HEADLIGHT, 1)] + [(r, Material.LAMP_ACCENT, 2) for r in rings]
        parts += [(c, Material.HEADLIGHT, 3) for c in inner]
    elif style == "angular":
        housing = cap.uv([(0.46, 0.70), (0.96, 0.76), (0.97, 0.95), (0.52, 0.90)])
        strip = cap.uv([(0.55, 0.72), (0.93, 0.77), (0.93, 0.80), (0.57, 0.75)])
        parts = [(housing, Material.HEADLIGHT, 1), (strip, Material.LAMP_ACCENT, 2)]
    elif style == "round":
        big = _circle((cap.half * 0.72, cap.v(0.55)), (85.0, 85.0), 20)
        small = _circle((cap.half * 0.72, cap.v(0.88)), (70.0, 35.0), 16)
        parts = [
            (big, Material.TRIM, 1),
            (_circle((cap.half * 0.72, cap.v(0.55)), (70.0, 70.0), 20), Material.HEADLIGHT, 2),
        ]
        parts.append((small, Material.HEADLIGHT, 1))
    elif style == "slit":
        slit = cap.uv([(0.45, 0.80), (0.97, 0.86), (0.97, 0.96), (0.58, 0.93)])
        parts = [
            (slit, Material.HEADLIGHT, 1),
            (cap.uv([(0.6, 0.85), (0.93, 0.89), (0.93, 0.91), (0.62, 0.88)]), Material.LAMP_ACCENT, 2),
        ]
    elif style == "drop":
        centre = (cap.half * 0.72, cap.v(0.80))
        parts = [(_circle(centre, (cap.half * 0.24, (cap.z1 - cap.z0) * 0.15), 18), Material.HEADLIGHT, 1)]
        parts += [
            (_circle((centre[0] + dy, centre[1] + dz), (16.0, 16.0), 8), Material.LAMP_ACCENT, 2)
            for dy in (-35.0, 35.0)
            for dz in (-22.0, 22.0)
        ]
    else:
        parts = [(cap.uv([(0.5, 0.72), (0.95, 0.72), (0.95, 0.93), (0.5, 0.93)]), Material.HEADLIGHT, 1)]
    for yz, material, layer in parts:
        decals += [(side, material, layer) for side in _both_sides(yz)]
    return decals


def _grille(cap: _CapFrame, style: str) -> list[tuple[np.ndarray, Material, int]]:
    """Grille and lower intakes on the front face, centred on y = 0."""
    h = cap.z1 - cap.z0
    decals: list[tuple[np.ndarray, Material, int]] = []
    intake = (
        _rounded_rect(-cap.half * 0.75, cap.half * 0.75, cap.v(0.04), cap.v(0.16), 30.0),
        Material.TRIM,
        1,
    )
    if style == "kidney":
        for y0, y1 in ((0.03, 0.30), (-0.30, -0.03)):
            y0_mm, y1_mm = cap.half * y0, cap.half * y1
            decals.append((_rounded_rect(y0_mm, y1_mm, cap.v(0.52), cap.v(0.93), 60.0), Material.CHROME, 1))
            inner = _rounded_rect(y0_mm + 15, y1_mm - 15, cap.v(0.52) + 15, cap.v(0.93) - 15, 50.0)
            decals.append((inner, Material.GRILLE, 2))
        decals.append(intake)
    elif style in ("upright", "wide_bars", "big_bars"):
        width = {"upright": 0.32, "wide_bars": 0.45, "big_bars": 0.55}[style]
        v0 = {"upright": 0.50, "wide_bars": 0.52, "big_bars": 0.42}[style]
        decals.append(
            (
                _rounded_rect(-cap.half * width, cap.half * width, cap.v(v0), cap.v(0.94), 25.0),
                Material.CHROME,
                1,
            )
        )
        decals.append(
            (
                _rect(-cap.half * width + 22, cap.half * width - 22, cap.v(v0) + 20, cap.v(0.94) - 20),
                Material.GRILLE,
                2,
            )
        )
        bars = {"upright": 3, "wide_bars": 2, "big_bars": 2}[style]
        for j in range(bars):
            zc = cap.v(v0) + (j + 1) * (cap.v(0.94) - cap.v(v0)) / (bars + 1)
            thickness = 28.0 if style == "big_bars" else 14.0
            decals.append(
                (
                    _rect(
                        -cap.half * width + 22, cap.half * width - 22, zc - thickness / 2, zc + thickness / 2
                    ),
                    Material.CHROME,
                    3,
                )
            )
        if style != "big_bars":
            centre = (0.0, (cap.v(v0) + cap.v(0.94)) / 2)
            decals.append((_circle(centre, (60.0, 60.0), 16), Material.CHROME, 4))
            decals.append((_circle(centre, (45.0, 45.0), 16), Material.GRILLE, 5))
        decals.append(intake)
    elif style == "chevron":
        decals.append(
            (
                _rounded_rect(-cap.half * 0.5, cap.half * 0.5, cap.v(0.55), cap.v(0.86), 30.0),
                Material.GRILLE,
                1,
            )
        )
        for dz in (0.0, 0.11):
            chevron = cap.uv(
                [
                    (-0.42, 0.62 + dz),
                    (0.0, 0.72 + dz),
                    (0.42, 0.62 + dz),
                    (0.42, 0.67 + dz),
                    (0.0, 0.77 + dz),
                    (-0.42, 0.67 + dz),
                ]
            )
            decals.append((chevron, Material.CHROME, 2))
        decals.append(intake)
    elif style == "intake":
        for side in _both_sides(cap.uv([(0.42, 0.10), (0.90, 0.12), (0.94, 0.55), (0.48, 0.50)])):
            decals.append((side, Material.GRILLE, 1))
        decals.append(
            (cap.uv([(-0.36, 0.02), (0.36, 0.02), (0.30, 0.15), (-0.30, 0.15)]), Material.GRILLE, 1)
        )
    elif style == "wing":
        decals.append(
            (cap.uv([(-0.34, 0.55), (0.34, 0.55), (0.40, 0.78), (-0.40, 0.78)]), Material.GRILLE, 1)
        )
        decals.append(
            (cap.uv([(-0.55, 0.78), (0.55, 0.78), (0.52, 0.90), (-0.52, 0.90)]), Material.CHROME, 1)
        )
        decals.append(intake)
    elif style == "oval":
        centre = (0.0, cap.v(0.72))
        decals.append((_circle(centre, (cap.half * 0.36, h * 0.17), 20), Material.CHROME, 1))
        decals.append((_circle(centre, (cap.half * 0.36 - 18, h * 0.17 - 18), 20), Material.GRILLE, 2))
        decals.append(intake)
    elif style == "volvo":
        decals.append(
            (cap.uv([(-0.34, 0.52), (0.34, 0.52), (0.38, 0.90), (-0.38, 0.90)]), Material.GRILLE, 1)
        )
        decals.append(
            (cap.uv([(-0.34, 0.58), (-0.30, 0.56), (0.34, 0.84), (0.30, 0.86)]), Material.CHROME, 2)
        )
        decals.append((_circle((0.0, cap.v(0.71)), (45.0, 45.0), 14), Material.CHROME, 3))
        decals.append(intake)
    elif style == "slot":
        decals.append(
            (cap.uv([(-0.25, 0.80), (0.25, 0.80), (0.22, 0.84), (-0.22, 0.84)]), Material.CHROME, 1)
        )
        decals.append(
            (
                _rounded_rect(-cap.half * 0.45, cap.half * 0.45, cap.v(0.05), cap.v(0.20), 40.0),
                Material.GRILLE,
                1,
            )
        )
    return decals


def _taillights(cap: _CapFrame, style: str) -> list[tuple[np.ndarray, Material, int]]:
    """Tail lights (mirrored about y = 0) and any trim across the rear face between them."""
    decals: list[tuple[np.ndarray, Material, int]] = []
    centre: list[tuple[np.ndarray, Material, int]] = []
    if style == "lbar":
        parts = [
            (cap.uv([(0.55, 0.72), (0.97, 0.72), (0.97, 0.97), (0.55, 0.97)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.62, 0.77), (0.92, 0.77), (0.92, 0.82), (0.62, 0.82)]), Material.LAMP_ACCENT, 2),
            (cap.uv([(0.88, 0.50), (0.97, 0.50), (0.97, 0.72), (0.88, 0.72)]), Material.TAILLIGHT, 1),
        ]
    elif style == "wrap":
        parts = [
            (cap.uv([(0.50, 0.68), (0.98, 0.64), (0.98, 0.96), (0.56, 0.96)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.60, 0.72), (0.75, 0.72), (0.75, 0.82), (0.60, 0.82)]), Material.REVERSE_LIGHT, 2),
        ]
    elif style == "trapezoid":
        parts = [
            (cap.uv([(0.52, 0.78), (0.97, 0.62), (0.97, 0.95), (0.55, 0.95)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.62, 0.82), (0.92, 0.75), (0.92, 0.78), (0.62, 0.85)]), Material.LAMP_ACCENT, 2),
        ]
    elif style == "vertical":
        parts = [
            (cap.uv([(0.83, 0.30), (0.98, 0.30), (0.98, 0.98), (0.83, 0.98)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.85, 0.55), (0.96, 0.55), (0.96, 0.65), (0.85, 0.65)]), Material.REVERSE_LIGHT, 2),
        ]
    elif style == "slit":
        parts = [
            (cap.uv([(0.42, 0.84), (0.97, 0.80), (0.97, 0.95), (0.45, 0.93)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.40, 0.05), (0.85, 0.05), (0.80, 0.40), (0.45, 0.40)]), Material.GRILLE, 1),
        ]
    elif style == "full_width":
        parts = [
            (cap.uv([(0.0, 0.84), (0.97, 0.84), (0.97, 0.89), (0.0, 0.89)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.62, 0.72), (0.97, 0.72), (0.97, 0.95), (0.66, 0.95)]), Material.TAILLIGHT, 1),
        ]
    elif style == "round":
        parts = [
            (
                _rounded_rect(cap.half * 0.74, cap.half * 0.97, cap.v(0.50), cap.v(0.97), 50.0),
                Material.CHROME,
                1,
            ),
            (
                _rounded_rect(
                    cap.half * 0.74 + 12, cap.half * 0.97 - 12, cap.v(0.50) + 12, cap.v(0.97) - 12, 40.0
                ),
                Material.TAILLIGHT,
                2,
            ),
            (_circle((cap.half * 0.855, cap.v(0.68)), (28.0, 28.0), 12), Material.REVERSE_LIGHT, 3),
        ]
    elif style == "chrome_bar":
        parts = [
            (cap.uv([(0.58, 0.70), (0.97, 0.66), (0.97, 0.95), (0.62, 0.95)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.66, 0.80), (0.92, 0.78), (0.92, 0.83), (0.66, 0.85)]), Material.LAMP_ACCENT, 2),
        ]
        centre = [(cap.uv([(-0.60, 0.74), (0.60, 0.74), (0.60, 0.82), (-0.60, 0.82)]), Material.CHROME, 1)]
    elif style == "boomerang":
        parts = [
            (cap.uv([(0.40, 0.92), (0.97, 0.70), (0.98, 0.97), (0.45, 0.98)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.86, 0.45), (0.98, 0.45), (0.98, 0.70), (0.90, 0.75)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.70, 0.12), (0.92, 0.12), (0.92, 0.18), (0.70, 0.18)]), Material.TAILLIGHT, 1),
        ]
    elif style == "chevron_bar":
        parts = [
            (cap.uv([(0.56, 0.68), (0.98, 0.64), (0.98, 0.96), (0.60, 0.96)]), Material.TAILLIGHT, 1),
            (cap.uv([(0.64, 0.74), (0.78, 0.74), (0.78, 0.84), (0.64, 0.84)]), Material.REVERSE_LIGHT, 2),
        ]
        centre = [
            (cap.uv([(-0.56, 0.70), (0.56, 0.70), (0.56, 0.74), (-0.56, 0.74)]), Material.CHROME, 1),
        ] + [
            (
                cap.uv([(-0.14, 0.78 + dz), (0.0, 0.84 + dz), (0.14, 0.78 + dz), (0.14, 0.81 + dz),
                        (0.0, 0.87 + dz), (-0.14, 0.81 + dz)]),
                Material.CHROME,
                1,
            )
            for dz in (0.0, 0.07)
        ]
    else:
        raise ValueError(f"unknown tail-light style {style!r}")
    for yz, material, layer in parts:
        decals += [(side, material, layer) for side in _both_sides(yz)]
    return decals + centre


def _cap_frame(ring: np.ndarray) -> _CapFrame:
    y_half = float(np.max(ring[:, 1])) - 40.0
    return _CapFrame(
        float(ring[0, 0]), y_half, float(ring[:, 2].min()) + 15.0, float(ring[:, 2].max()) - 15.0
    )


def _add_decals(
    builder: _MeshBuilder, parent: int, cap: _CapFrame, decals: list[tuple[np.ndarray, Material, int]]
) -> None:
    for yz, material, layer in decals:
        builder.decal(parent, cap.to_3d(yz), material, layer)


def _add_wheel(builder: _MeshBuilder, model: CarModel, x_axle: float, y_centre: float) -> None:
    """Tyre (tread and sidewalls) and the rim face with spokes, on the outer side."""
    s = model.shape
    r, half_w = s.wheel_radius_mm, s.tyre_width_mm / 2
    side = np.sign(y_centre)
    angles = np.linspace(0, 2 * np.pi, WHEEL_SEGMENTS, endpoint=False)
    ring = np.column_stack([x_axle + r * np.cos(angles), r + r * np.sin(angles)])
    y_in, y_out = y_centre - side * half_w, y_centre + side * half_w
    for j in range(WHEEL_SEGMENTS):
        a, b = ring[j], ring[(j + 1) % WHEEL_SEGMENTS]
        quad = np.array([(a[0], y_in, a[1]), (a[0], y_out, a[1]), (b[0], y_out, b[1]), (b[0], y_in, b[1])])
        radial = np.array([(a[0] + b[0]) / 2 - x_axle, 0.0, (a[1] + b[1]) / 2 - r])
        builder.surface(quad, Material.TYRE, radial)
    builder.surface(
        np.column_stack([ring[:, 0], np.full(len(ring), y_in), ring[:, 1]]),
        Material.TYRE,
        np.array([0.0, -side, 0.0]),
    )
    outer = builder.surface(
        np.column_stack([ring[:, 0], np.full(len(ring), y_out), ring[:, 1]]),
        Material.TYRE,
        np.array([0.0, side, 0.0]),
    )
    assert outer is not None

    def on_side(xz: np.ndarray) -> np.ndarray:
        return np.column_stack([xz[:, 0], np.full(len(xz), y_out), xz[:, 1]])

    rim = _circle((x_axle, r), (0.66 * r, 0.66 * r), WHEEL_SEGMENTS)
    builder.decal(outer, on_side(rim), Material.HUB, 1)
    spokes = model.details.hub_spokes
    for j in range(spokes):
        a0 = 2 * np.pi * j / spokes + np.pi / spokes * 0.35
        a1 = 2 * np.pi * (j + 1) / spokes - np.pi / spokes * 0.35
        arc = np.linspace(a0, a1, 4)
        outer_arc = np.column_stack([x_axle + 0.56 * r * np.cos(arc), r + 0.56 * r * np.sin(arc)])
        inner_arc = np.column_stack([x_axle + 0.22 * r * np.cos(arc[::-1]), r + 0.22 * r * np.sin(arc[::-1])])
        builder.decal(outer, on_side(np.vstack([outer_arc, inner_arc])), Material.HUB_DARK, 2)
    builder.decal(outer, on_side(_circle((x_axle, r), (0.13 * r, 0.13 * r), 10)), Material.HUB, 3)


def _add_mirrors(builder: _MeshBuilder, model: CarModel, profile: _Profile) -> None:
    """Door mirrors: small boxes at the base of the A-pillars (outside the published width)."""
    for corners in _mirror_corners(model, profile):
        centre = corners.mean(axis=0)
        for axis in range(3):
            for end in (0, 1):
                face = corners[[i for i in range(8) if (i >> (2 - axis)) & 1 == end]]
                face = face[[0, 1, 3, 2]]
                builder.surface(face, Material.MIRROR, face.mean(axis=0) - centre)


def _plate_heights_mm(front_cap: _CapFrame, rear_cap: _CapFrame) -> tuple[float, float]:
    """Height of the centre of the front and rear licence plates."""
    return (front_cap.v(0.0) + max(0.26 * (front_cap.z1 - front_cap.z0), 95.0),
            rear_cap.v(0.0) + 0.42 * (rear_cap.z1 - rear_cap.z0))


@cache
def _body(model: CarModel) -> tuple[_Profile, np.ndarray, _CapFrame, _CapFrame]:
    """The lofted body's profile, cross-section rings and front and rear faces."""
    profile = _Profile(model)
    xs, bottoms = _stations(model, profile)
    rings = _rings(model, profile, xs, bottoms)
    return profile, rings, _cap_frame(rings[0]), _cap_frame(rings[-1])


def plate_corners_car_mm(model: CarModel) -> dict[str, np.ndarray]:
    """Corners (4, 3) of the front and rear licence plates in the car frame, counter-clockwise seen from
    outside the car, starting at the lower corner on the car's right."""
    _, _, front_cap, rear_cap = _body(model)
    w, h = PLATE_SIZE_MM
    corners = {}
    for end, cap, z, sign in (("front", front_cap, _plate_heights_mm(front_cap, rear_cap)[0], 1.0),
                              ("rear", rear_cap, _plate_heights_mm(front_cap, rear_cap)[1], -1.0)):
        ys = np.array([-w / 2, w / 2, w / 2, -w / 2]) * sign
        zs = np.array([z - h / 2, z - h / 2, z + h / 2, z + h / 2])
        corners[end] = np.column_stack([np.full(4, cap.x), ys, zs])
    return corners


def _mirror_corners(model: CarModel, profile: _Profile) -> list[np.ndarray]:
    """The eight corners of each door mirror: small boxes at the base of the A-pillars."""
    x0 = profile.x_cowl - 0.22 * model.shape.windscreen_run_mm
    z0 = float(profile.belt(x0)) + 40.0
    half = float(profile.half_width(x0)) - 40.0
    mirrors = []
    for side in (-1.0, 1.0):
        lo = np.array([x0 - 130.0, side * half, z0])
        hi = np.array([x0, side * (half + 190.0), z0 + 110.0])
        mirrors.append(np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for c in (lo[2], hi[2])]))
    return mirrors


def convex_parts_car_mm(model: CarModel) -> tuple[np.ndarray, ...]:
    """The car's outline as convex parts in the car frame: slabs of the lofted body between every other
    cross-section, the four tyres and the two mirrors (each part the points whose convex hull it is)."""
    profile, rings, _, _ = _body(model)
    stations = list(range(0, len(rings), 2)) + ([len(rings) - 1] if (len(rings) - 1) % 2 else [])
    parts = [np.vstack([rings[a], rings[b]]) for a, b in zip(stations, stations[1:])]
    s = model.shape
    angles = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    for x_axle, track in ((model.front_axle_x_mm, model.track_front_mm), (model.rear_axle_x_mm, model.track_rear_mm)):
        circle = np.column_stack([x_axle + s.wheel_radius_mm * np.cos(angles), np.zeros(16),
                                  s.wheel_radius_mm * (1 + np.sin(angles))])
        for y_centre in (-track / 2, track / 2):
            parts += [np.vstack([circle + [0.0, y_centre + dy, 0.0] for dy in (-s.tyre_width_mm / 2, s.tyre_width_mm / 2)])]
    return tuple(parts + _mirror_corners(model, profile))


@cache
def build_car_mesh(model: CarModel, plates: bool = True) -> Mesh:
    """The model's mesh in the car frame, with or without its licence plates (cached per model)."""
    profile, rings, front_cap, rear_cap = _body(model)
    builder = _MeshBuilder()
    front, rear = _loft(builder, model, profile, rings)
    _add_mirrors(builder, model, profile)
    front_plate_z, rear_plate_z = _plate_heights_mm(front_cap, rear_cap)
    front_decals = _grille(front_cap, model.details.grille) + _headlights(front_cap, model.details.headlight)
    if plates:
        front_decals += _plate(front_cap, front_plate_z)
    _add_decals(builder, front, front_cap, front_decals)
    rear_decals = _taillights(rear_cap, model.details.taillight)
    if plates:
        rear_decals += _plate(rear_cap, rear_plate_z)
    _add_decals(builder, rear, rear_cap, rear_decals)
    for x_axle, track in (
        (model.front_axle_x_mm, model.track_front_mm),
        (model.rear_axle_x_mm, model.track_rear_mm),
    ):
        for side in (-1.0, 1.0):
            _add_wheel(builder, model, x_axle, side * track / 2)
    return builder.build()


def catalog_shapes() -> dict[int, VehicleShape]:
    """The shape of every catalog model, by model id (what `misc/vehicle_shapes.json` of the demo set holds)."""
    return {model.model_id: VehicleShape(convex_parts_car_mm(model)) for model in CATALOG}
