"""Vehicle shapes: the 3D outline of a car model as a few convex parts in the car frame, for fitting the
predicted model to a silhouette. A vehicle-shapes file maps model ids to shapes; a model without one is a
cuboid of its length, width and height.

Car frame (mm): origin at the centre of the footprint on the ground, +x forward, +y to the car's left,
+z up. File (JSON): {"format": FORMAT, "models": {"<model id>": [part, ...]}}, a part being a list of
[x, y, z] points whose convex hull is that part of the car.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from vehloc.atomic import write_text
from vehloc.data.text import read_json
from vehloc.errors import DataError

FORMAT = "vehloc vehicle shapes 1"
ON_ROAD_MM = 1.0
"""A part whose lowest point is this close to the road stands on it (a tyre)."""
SHAPES_FILE = "misc/vehicle_shapes.json"
"""Where a CompCars-format root keeps its models' shapes (vehloc's addition to the layout; optional)."""


@dataclass(frozen=True, eq=False)
class VehicleShape:
    """A car's outline as convex parts: each an (N, 3) array of points in the car frame, mm."""

    parts: tuple[np.ndarray, ...]

    @classmethod
    def cuboid(cls, length_mm: float, width_mm: float, height_mm: float) -> VehicleShape:
        """The box of the dimensions, standing on the road around the car frame's origin."""
        corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (0.0, 1.0)])
        return cls((corners * [length_mm, width_mm, height_mm],))

    @cached_property
    def points_mm(self) -> np.ndarray:
        """All the parts' points, (M, 3)."""
        return np.concatenate(self.parts)

    @cached_property
    def axle_middle_x_mm(self) -> float:
        """Where the middle between the axles lies along the car (x, mm): the mean of the x-middles of the parts
        that stand on the road (the tyres; within `ON_ROAD_MM` of it). A cuboid's one part gives 0: the axles'
        middle at the side's, as the paper's wheel placement assumes."""
        standing = [part for part in self.parts if part[:, 2].min() <= ON_ROAD_MM]
        if not standing:
            return 0.0
        return float(np.mean([(part[:, 0].min() + part[:, 0].max()) / 2.0 for part in standing]))

    @cached_property
    def part_starts(self) -> np.ndarray:
        """Where each part after the first starts in `points_mm` (for `np.split`)."""
        return np.cumsum([len(part) for part in self.parts])[:-1]

    def to_json(self) -> list[list[list[float]]]:
        return [np.round(part, 1).tolist() for part in self.parts]


def shapes_from_json(content: object, source: str) -> dict[int, VehicleShape]:
    """Shapes from the parsed content of a vehicle-shapes file; DataError naming `source` otherwise."""
    if not isinstance(content, dict) or content.get("format") != FORMAT or not isinstance(content.get("models"), dict):
        raise DataError(f"{source}: not a vehicle-shapes file (expected format {FORMAT!r} and 'models')")
    shapes = {}
    for key, parts in content["models"].items():
        try:
            arrays = tuple(np.asarray(part, dtype=float) for part in parts)
        except (TypeError, ValueError):
            raise DataError(f"{source}: model {key}: parts must be lists of [x, y, z] points") from None
        if not key.isdigit() or not arrays or any(a.ndim != 2 or a.shape[1] != 3 or len(a) < 4 for a in arrays):
            raise DataError(f"{source}: model {key}: expected an integer id and parts of at least 4 [x, y, z] points")
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise DataError(f"{source}: model {key}: points must be finite")
        shapes[int(key)] = VehicleShape(arrays)
    return shapes


def read_shapes(path: str | Path) -> dict[int, VehicleShape]:
    """The shapes of a vehicle-shapes file, by model id."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: vehicle-shapes file does not exist")
    return shapes_from_json(read_json(path), str(path))


def shapes_to_json(shapes: dict[int, VehicleShape]) -> dict[str, object]:
    return {"format": FORMAT, "models": {str(model_id): shape.to_json() for model_id, shape in sorted(shapes.items())}}


def write_shapes(path: str | Path, shapes: dict[int, VehicleShape]) -> Path:
    """Write a vehicle-shapes file atomically."""
    return write_text(path, json.dumps(shapes_to_json(shapes)))
