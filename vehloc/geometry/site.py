"""Site description: surveyed world corners of lane markers and a rough initial guess of the view.

YAML format (world coordinates in mm, the paper's frame: X across the road to the right, Y along it):

    name: my_site
    image_size_px: [1280, 720]          # optional, checked against the calibrated image
    markers:                            # 4 distinct corners each, enclosing an area
      - id: lane1_dash0
        corners_mm: [[-75, 0], [75, 0], [75, 3000], [-75, 3000]]
    stripes:                            # optional: solid lines (no corners), centre line and width
      - {id: edge_right, from_mm: [3600, 0], to_mm: [3600, 90000], width_mm: 150}
    initial_guess:                      # one of the two
      points:                           # at least 4 approximate correspondences, not collinear
        - {world_mm: [-75, 0], image_px: [612, 650]}
      homography: [[...], [...], [...]] # world (X, Y, 1) mm -> image px
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import yaml

from vehloc.data.text import read_yaml
from vehloc.errors import VehlocError
from vehloc.geometry.projective import ProjectiveTransform


class SiteError(VehlocError):
    """A site file is missing, malformed or geometrically degenerate."""


@dataclass(frozen=True)
class SiteMarker:
    """A surveyed marker: an id and its corners in world mm (N, 2)."""

    marker_id: str
    corners_mm: np.ndarray


@dataclass(frozen=True)
class SiteStripe:
    """A solid painted line without usable corners (an edge line): its centre line and width, in mm."""

    stripe_id: str
    start_mm: tuple[float, float]
    end_mm: tuple[float, float]
    width_mm: float


@dataclass(frozen=True)
class Site:
    """Surveyed markers of a camera site and a rough initial homography (world mm -> image px)."""

    name: str
    markers: tuple[SiteMarker, ...]
    initial_homography: np.ndarray
    image_size_px: tuple[int, int] | None = None
    guess_points: tuple[tuple[tuple[float, float], tuple[float, float]], ...] = field(default=())
    stripes: tuple[SiteStripe, ...] = field(default=())
    source: str = ""
    """The site file it was read from ("" when made in memory)."""

    @property
    def label(self) -> str:
        """How messages name the site: its file, else its name."""
        return self.source or f"site {self.name!r}"

    def initial_transform(self, image_size_px: tuple[int, int] | None = None) -> ProjectiveTransform:
        """The rough road-to-image transform of the initial guess. Its visible side is that of the clicked
        points, or, for a guess given as a matrix, that of the road at the bottom of the image
        (`image_size_px` (width, height), else the site's own)."""
        if self.guess_points:
            return ProjectiveTransform.seen_from(self.initial_homography, np.array(self.guess_points[0][1]))
        size = image_size_px or self.image_size_px
        if size is None:
            raise SiteError(f"{self.label}: give image_size_px to tell which side of the guess's horizon is seen")
        return ProjectiveTransform.road_to_image(self.initial_homography, *size)

    def world_corners_mm(self) -> tuple[np.ndarray, list[str]]:
        """All surveyed corners (M, 2) and their labels `marker_id:k`."""
        corners = np.concatenate([m.corners_mm for m in self.markers]).reshape(-1, 2)
        labels = [f"{m.marker_id}:{k}" for m in self.markers for k in range(len(m.corners_mm))]
        return corners, labels


def collinearity_ratio(points: np.ndarray) -> float:
    """Smallest over largest singular value of the centred points: 0 when they lie on one line."""
    centred = np.asarray(points, dtype=float) - np.mean(points, axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    return float(singular[-1] / singular[0]) if singular[0] > 0 else 0.0


def homography_from_points(world_mm: np.ndarray, image_px: np.ndarray, where: str) -> np.ndarray:
    """Least-squares homography from >= 4 non-collinear correspondences; SiteError otherwise."""
    world_mm = np.asarray(world_mm, dtype=float).reshape(-1, 2)
    image_px = np.asarray(image_px, dtype=float).reshape(-1, 2)
    if len(world_mm) < 4:
        raise SiteError(f"{where}: {len(world_mm)} point(s) given, a homography needs at least 4")
    for name, points in (("world", world_mm), ("image", image_px)):
        if collinearity_ratio(points) < 1e-3:
            raise SiteError(f"{where}: the {name} points are collinear; a homography needs 4 points in general position")
    homography, _ = cv2.findHomography(world_mm, image_px, 0)
    if homography is None:
        raise SiteError(f"{where}: no homography fits these points")
    return homography


def _parse_pair(value: object, where: str) -> tuple[float, float]:
    if not (isinstance(value, (list, tuple)) and len(value) == 2):
        raise SiteError(f"{where}: expected a pair [x, y], got {value!r}")
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
        raise SiteError(f"{where}: expected two numbers, got {value!r}")
    pair = float(value[0]), float(value[1])
    if not all(math.isfinite(v) for v in pair):
        raise SiteError(f"{where}: expected finite numbers, got {value!r}")
    return pair


MIN_MARKER_AREA_MM2 = 100.0
"""A marker's corners must span at least this area (1 cm^2): four identical or collinear corners are a
typing error, not a marker."""


def polygon_area(points: np.ndarray) -> float:
    """The area of a simple polygon (shoelace formula)."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _parse_markers(raw: object, path: Path) -> tuple[SiteMarker, ...]:
    if not isinstance(raw, list) or not raw:
        raise SiteError(f"{path}: 'markers' must be a non-empty list")
    markers = []
    for i, entry in enumerate(raw):
        where = f"{path}: markers[{i}]"
        if not isinstance(entry, dict) or "corners_mm" not in entry:
            raise SiteError(f"{where} needs 'id' and 'corners_mm'")
        raw_corners = entry["corners_mm"]
        if not isinstance(raw_corners, list) or len(raw_corners) != 4:
            count = len(raw_corners) if isinstance(raw_corners, list) else "no list of"
            raise SiteError(f"{where}.corners_mm: a marker has 4 corners, got {count}")
        corners = np.array([_parse_pair(c, f"{where}.corners_mm[{k}]") for k, c in enumerate(raw_corners)])
        if len({tuple(c) for c in corners.tolist()}) < 4:
            raise SiteError(f"{where}.corners_mm: two or more corners are the same point")
        if polygon_area(corners) < MIN_MARKER_AREA_MM2:
            raise SiteError(f"{where}.corners_mm: the corners enclose no area (they lie on one line)")
        markers.append(SiteMarker(str(entry.get("id", i)), corners))
    ids = [m.marker_id for m in markers]
    duplicated = sorted({i for i in ids if ids.count(i) > 1})
    if duplicated:
        raise SiteError(f"{path}: marker id(s) {', '.join(duplicated)} given twice")
    return tuple(markers)


def _parse_stripes(raw: object, path: Path) -> tuple[SiteStripe, ...]:
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise SiteError(f"{path}: 'stripes' must be a list")
    stripes = []
    for i, entry in enumerate(raw):
        where = f"{path}: stripes[{i}]"
        if not isinstance(entry, dict) or not {"from_mm", "to_mm", "width_mm"} <= set(entry):
            raise SiteError(f"{where} needs 'from_mm', 'to_mm' and 'width_mm'")
        start, end = _parse_pair(entry["from_mm"], f"{where}.from_mm"), _parse_pair(entry["to_mm"], f"{where}.to_mm")
        width = entry["width_mm"]
        if isinstance(width, bool) or not isinstance(width, (int, float)) or not math.isfinite(width) or width <= 0:
            raise SiteError(f"{where}.width_mm: expected a positive number, got {width!r}")
        if start == end:
            raise SiteError(f"{where}: from_mm and to_mm are the same point")
        stripes.append(SiteStripe(str(entry.get("id", i)), start, end, float(width)))
    return tuple(stripes)


def _parse_image_size(raw: object, path: Path) -> tuple[int, int] | None:
    if raw is None:
        return None
    where = f"{path}: image_size_px"
    if not (isinstance(raw, (list, tuple)) and len(raw) == 2) or any(
        isinstance(v, bool) or not isinstance(v, (int, float)) or not float(v).is_integer() or v < 1 for v in raw
    ):
        raise SiteError(f"{where}: expected [width, height], two positive integers, got {raw!r}")
    return int(raw[0]), int(raw[1])


def _parse_homography(raw: object, path: Path) -> np.ndarray:
    try:
        homography = np.array(raw, dtype=float)
    except (TypeError, ValueError):
        homography = np.zeros(0)
    if homography.shape != (3, 3) or not np.all(np.isfinite(homography)) or abs(np.linalg.det(homography)) < 1e-12:
        raise SiteError(f"{path}: initial_guess.homography must be an invertible 3x3 matrix of finite numbers")
    if abs(homography[2, 2]) < 1e-12:
        raise SiteError(f"{path}: initial_guess.homography has 0 in its lower-right entry; scale it to 1")
    return homography


def read_site(path: Path | str) -> Site:
    """Read and validate a site file (UTF-8 YAML); SiteError naming the file and the entry that is wrong."""
    path = Path(path)
    if not path.is_file():
        raise SiteError(f"{path}: site file does not exist" + (" (it is a folder)" if path.is_dir() else ""))
    content = read_yaml(path, SiteError)
    if not isinstance(content, dict):
        raise SiteError(f"{path}: expected a mapping with 'markers' and 'initial_guess'")
    name = content.get("name", path.stem)
    if not isinstance(name, (str, int)) or isinstance(name, bool):
        raise SiteError(f"{path}: name must be a string, got {name!r}")
    markers = _parse_markers(content.get("markers"), path)
    guess = content.get("initial_guess")
    if not isinstance(guess, dict) or not ({"points", "homography"} & set(guess)):
        raise SiteError(f"{path}: 'initial_guess' needs 'points' (at least 4) or 'homography'")
    guess_points: tuple = ()
    if "homography" in guess:
        homography = _parse_homography(guess["homography"], path)
    else:
        points = guess["points"]
        if not isinstance(points, list):
            raise SiteError(f"{path}: initial_guess.points must be a list")
        guess_points = tuple(
            (
                _parse_pair(p.get("world_mm") if isinstance(p, dict) else None, f"{path}: initial_guess.points[{i}].world_mm"),
                _parse_pair(p.get("image_px") if isinstance(p, dict) else None, f"{path}: initial_guess.points[{i}].image_px"),
            )
            for i, p in enumerate(points)
        )
        world = np.array([w for w, _ in guess_points])
        image = np.array([im for _, im in guess_points])
        homography = homography_from_points(world, image, f"{path}: initial_guess.points")
    image_size = _parse_image_size(content.get("image_size_px"), path)
    stripes = _parse_stripes(content.get("stripes"), path)
    return Site(str(name), markers, homography / homography[2, 2], image_size, guess_points, stripes, str(path))


def site_yaml(site: Site) -> str:
    """The text of a site file (the initial guess as points when the site has them, else as a homography)."""
    content: dict[str, object] = {"name": site.name}
    if site.image_size_px is not None:
        content["image_size_px"] = list(site.image_size_px)
    content["markers"] = [
        {"id": m.marker_id, "corners_mm": [[round(float(x), 3), round(float(y), 3)] for x, y in m.corners_mm]}
        for m in site.markers
    ]
    if site.stripes:
        content["stripes"] = [
            {
                "id": s.stripe_id,
                "from_mm": [float(v) for v in s.start_mm],
                "to_mm": [float(v) for v in s.end_mm],
                "width_mm": float(s.width_mm),
            }
            for s in site.stripes
        ]
    if site.guess_points:
        content["initial_guess"] = {
            "points": [
                {"world_mm": [float(w[0]), float(w[1])], "image_px": [float(i[0]), float(i[1])]}
                for w, i in site.guess_points
            ]
        }
    else:
        content["initial_guess"] = {"homography": site.initial_homography.tolist()}
    return yaml.safe_dump(content, sort_keys=False)
