"""An oriented box (centre, axes, half-lengths) and the separating-axis overlap test: numpy."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from score4.shapes import Transform

#: Boxes that share less than this (mm) do not overlap (touching faces are fine).
TOLERANCE = 1e-9


@dataclass(frozen=True)
class OrientedBox:
    """An oriented box: centre, rotation (columns: its axes), half-lengths (mm)."""

    centre: np.ndarray
    rotation: np.ndarray
    half: np.ndarray

    @cached_property
    def transform(self) -> Transform:
        """The box's own frame (centre, axes) -> the world."""
        return Transform(self.rotation, self.centre)

    def corners(self) -> np.ndarray:
        signs = np.array([[a, b, c] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)], float)
        return self.transform.apply(signs * self.half)

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        c = self.corners()
        return c.min(axis=0), c.max(axis=0)

    def grid(self, n: int = 9) -> np.ndarray:
        """Points of an ``n`` x ``n`` x 3 grid filling the box (corners and edges included)."""
        s = np.linspace(-1, 1, n)
        q = np.stack(np.meshgrid(s, s, np.linspace(-1, 1, 3), indexing="ij"), -1).reshape(-1, 3)
        return self.transform.apply(q * self.half)

    def contains(self, points: np.ndarray, tol: float = TOLERANCE) -> np.ndarray:
        """True for points strictly inside the box (more than ``tol`` from its faces)."""
        q = self.transform.inverse_apply(np.asarray(points, float).reshape(-1, 3))
        return np.asarray((np.abs(q) < self.half - tol).all(axis=1))

    def overlaps(self, other: OrientedBox, tol: float = TOLERANCE) -> bool:
        """Separating-axis test: True when the boxes share volume (touching is fine)."""
        a, b = self.rotation, other.rotation
        axes = [a[:, i] for i in range(3)] + [b[:, i] for i in range(3)]
        axes += [np.cross(a[:, i], b[:, j]) for i in range(3) for j in range(3)]
        d = other.centre - self.centre
        for axis in axes:
            norm = np.linalg.norm(axis)
            if norm < 1e-12:
                continue
            axis = axis / norm
            ra = np.sum(self.half * np.abs(a.T @ axis))
            rb = np.sum(other.half * np.abs(b.T @ axis))
            if abs(d @ axis) >= ra + rb - tol:
                return False
        return True
