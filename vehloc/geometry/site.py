"""Site description: surveyed world corners of lane markers and a rough initial guess of the view.

YAML format (world coordinates in mm, the paper's frame: X across the road to the right, Y along it):

    name: my_site
    image_size_px: [1280, 720]          # optional, checked against the calibrated image
    markers:
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

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import yaml

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

    def initial_transform(self, image_size_px: tuple[int, int] | None = None) -> ProjectiveTransform:
        """The rough road-to-image transform of the initial guess. Its visible side is that of the clicked
        points, or, for a guess given as a matrix, that of the road at the bottom of the image
        (`image_size_px` (width, height), else the site's own)."""
        if self.guess_points:
            return ProjectiveTransform.seen_from(self.initial_homography, np.array(self.guess_points[0][1]))
        size = image_size_px or self.image_size_px
        if size is None:
            raise SiteError(f"site {self.name!r}: give image_size_px to tell which side of the guess's horizon is seen")
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
    try:
        return float(value[0]), float(value[1])
    except (TypeError, ValueError):
        raise SiteError(f"{where}: expected numbers, got {value!r}") from None


def _parse_markers(raw: object, path: Path) -> tuple[SiteMarker, ...]:
    if not isinstance(raw, list) or not raw:
        raise SiteError(f"{path}: 'markers' must be a non-empty list")
    markers = []
    for i, entry in enumerate(raw):
        if not isinstance(entry, dict) or "corners_mm" not in entry:
            raise SiteError(f"{path}: markers[{i}] needs 'id' and 'corners_mm'")
        corners = [_parse_pair(c, f"{path}: markers[{i}].corners_mm") for c in entry["corners_mm"]]
        markers.append(SiteMarker(str(entry.get("id", i)), np.array(corners, dtype=float)))
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
        width = float(entry["width_mm"])
        if start == end or not width > 0:
            raise SiteError(f"{where}: needs two distinct points and a positive width")
        stripes.append(SiteStripe(str(entry.get("id", i)), start, end, width))
    return tuple(stripes)


def read_site(path: Path | str) -> Site:
    """Read and validate a site file."""
    path = Path(path)
    if not path.is_file():
        raise SiteError(f"{path}: site file does not exist")
    try:
        content = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise SiteError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(content, dict):
        raise SiteError(f"{path}: expected a mapping with 'markers' and 'initial_guess'")
    markers = _parse_markers(content.get("markers"), path)
    guess = content.get("initial_guess")
    if not isinstance(guess, dict) or not ({"points", "homography"} & set(guess)):
        raise SiteError(f"{path}: 'initial_guess' needs 'points' (at least 4) or 'homography'")
    guess_points: tuple = ()
    if "homography" in guess:
        homography = np.array(guess["homography"], dtype=float)
        if homography.shape != (3, 3) or abs(np.linalg.det(homography)) < 1e-12:
            raise SiteError(f"{path}: initial_guess.homography must be an invertible 3x3 matrix")
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
    size = content.get("image_size_px")
    image_size = tuple(int(v) for v in _parse_pair(size, f"{path}: image_size_px")) if size is not None else None
    stripes = _parse_stripes(content.get("stripes"), path)
    return Site(
        str(content.get("name", path.stem)), markers, homography / homography[2, 2], image_size, guess_points, stripes
    )


def write_site(path: Path, site: Site) -> None:
    """Write a site file (the initial guess as points when the site has them, else as a homography)."""
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
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(content, sort_keys=False))
