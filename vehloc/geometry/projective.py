"""The one projective transform of the plane vehloc uses: the road homography (road mm -> image px), its
inverse (image px -> road mm) and compositions of them.

A homography maps ``(x, y, 1)`` to ``(u, v, w)`` and the point to ``(u / w, v / w)``. Points on the far
side of the horizon come out with the other sign of ``w`` (a road point behind the camera still has an
image, upside down), and points on the horizon with ``w = 0``. The transform therefore carries
``front_sign``, the sign of ``w`` on the visible side, and reports every point whose ``w`` is not of that
sign instead of dividing by it: as NaN from ``__call__``, in the mask of ``map`` and as an error from
``map_visible``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehloc.errors import VehlocError


class HorizonError(VehlocError):
    """Points lie at or beyond the horizon of a transform, where they have no image."""


def as_points_2d(points: np.ndarray) -> np.ndarray:
    """(N, 2) float array from (2,) or (N, 2) input."""
    array = np.asarray(points, dtype=float)
    if array.ndim == 1:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"expected points of shape (N, 2), got {np.shape(points)}")
    return array


@dataclass(frozen=True)
class MappedPoints:
    """Mapped points (N, 2), NaN where the source point has no image, and the mask of those that have."""

    points: np.ndarray
    visible: np.ndarray

    @property
    def all_visible(self) -> bool:
        return bool(self.visible.all())


@dataclass(frozen=True, eq=False)
class ProjectiveTransform:
    """A 3x3 homography with the sign of ``w`` on its visible side."""

    matrix: np.ndarray
    front_sign: float = 1.0

    def __post_init__(self) -> None:
        matrix = np.array(self.matrix, dtype=float)
        if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
            raise ValueError(f"a projective transform needs a finite 3x3 matrix, got shape {matrix.shape}")
        if np.linalg.matrix_rank(matrix) < 3:
            raise ValueError("a projective transform needs an invertible matrix")
        if self.front_sign not in (1.0, -1.0):
            raise ValueError(f"front_sign must be +1 or -1, got {self.front_sign}")
        matrix.setflags(write=False)
        object.__setattr__(self, "matrix", matrix)
        object.__setattr__(self, "front_sign", float(self.front_sign))

    @classmethod
    def seen_from(cls, matrix: np.ndarray, visible_target_px: np.ndarray) -> ProjectiveTransform:
        """A road-to-image homography whose visible side holds the road point imaged at `visible_target_px`
        (e.g. the middle of the image's bottom row, which shows the road in any road camera)."""
        source = np.linalg.solve(np.asarray(matrix, dtype=float), [*np.asarray(visible_target_px, dtype=float), 1.0])
        if source[2] == 0:
            raise HorizonError(f"pixel {tuple(visible_target_px)} lies on the horizon of this homography")
        # H (X, Y, 1) = (u, v, 1) / source[2]: the visible side's w has the sign of source[2]
        return cls(matrix, 1.0 if source[2] > 0 else -1.0)

    @classmethod
    def road_to_image(cls, matrix: np.ndarray, width_px: int, height_px: int) -> ProjectiveTransform:
        """A road (mm) -> image (px) homography of a `width_px` x `height_px` camera image, whose visible side
        is that of the road seen at the middle of the bottom row."""
        return cls.seen_from(matrix, np.array([(width_px - 1) / 2, height_px - 1.0]))

    @property
    def normalised_matrix(self) -> np.ndarray:
        """The matrix scaled so that its bottom-right entry is 1 (the usual way to write a homography)."""
        return self.matrix / self.matrix[2, 2]

    def homogeneous(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) images ``(u, v, w)`` of (N, 2) points, scaled so that ``w > 0`` on the visible side."""
        source = as_points_2d(points)
        return self.front_sign * (np.column_stack([source, np.ones(len(source))]) @ self.matrix.T)

    def map(self, points: np.ndarray) -> MappedPoints:
        """Images of (N, 2) points; NaN and not visible where ``w`` is zero or of the far side's sign."""
        mapped = self.homogeneous(points)
        w = mapped[:, 2]
        visible = np.isfinite(w) & (w > 1e-12 * np.abs(mapped[:, :2]).max(axis=1, initial=1.0))
        out = np.full((len(mapped), 2), np.nan)
        out[visible] = mapped[visible, :2] / w[visible, None]
        return MappedPoints(out, visible)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Images (N, 2) of (N, 2) points, NaN for those at or beyond the horizon."""
        return self.map(points).points

    def map_visible(self, points: np.ndarray, what: str = "point") -> np.ndarray:
        """Images (N, 2) of (N, 2) points that must all be visible; HorizonError naming them otherwise."""
        mapped = self.map(points)
        if not mapped.all_visible:
            hidden = np.flatnonzero(~mapped.visible)
            raise HorizonError(
                f"{len(hidden)} of {len(mapped.visible)} {what}(s) lie at or beyond the horizon "
                f"(first: {as_points_2d(points)[hidden[0]].round(2).tolist()})"
            )
        return mapped.points

    def jacobian(self, points: np.ndarray) -> np.ndarray:
        """(N, 2, 2) derivatives of the mapped points by the source points, d(x', y') / d(x, y), at (N, 2)
        points (NaN where a point has no image)."""
        mapped = self.homogeneous(points)
        w = mapped[:, 2]
        image = mapped[:, :2] / w[:, None]
        rows = self.front_sign * (self.matrix[:2, :2][None] - image[:, :, None] * self.matrix[2, :2][None, None])
        return rows / w[:, None, None]

    def is_visible(self, points: np.ndarray) -> np.ndarray:
        """(N,) mask of the points on the visible side."""
        return self.map(points).visible

    @property
    def inverse(self) -> ProjectiveTransform:
        """The transform from destination back to source; the visible side keeps its sign."""
        return ProjectiveTransform(np.linalg.inv(self.matrix), self.front_sign)

    def __matmul__(self, other: ProjectiveTransform) -> ProjectiveTransform:
        """``(self @ other)(p) == self(other(p))`` for points visible to both."""
        return ProjectiveTransform(self.matrix @ other.matrix, self.front_sign * other.front_sign)

    def map_lines(self, lines: np.ndarray) -> np.ndarray:
        """Images (N, 3) of homogeneous lines (N, 3) ``a x + b y + c = 0`` of the source plane."""
        return np.asarray(lines, dtype=float).reshape(-1, 3) @ np.linalg.inv(self.matrix)
