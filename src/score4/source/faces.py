"""Faces of box volumes as rectangles in space."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_AXIS = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Rectangle:
    """A planar rectangle: ``origin + s*u + t*v`` for s, t in [0, 1]; ``normal`` points out of the volume."""

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    normal: np.ndarray

    @property
    def area(self) -> float:
        return float(np.linalg.norm(np.cross(self.u, self.v)))

    def triangles(self) -> np.ndarray:
        """The rectangle as two triangles, (2, 3, 3), counter-clockwise seen from outside."""
        o, u, v = self.origin, self.u, self.v
        tri = np.array([[o, o + u, o + u + v], [o, o + u + v, o + v]])
        if np.dot(np.cross(u, v), self.normal) < 0:
            tri = tri[:, ::-1]
        return tri


def box_face(center, size, face: str) -> Rectangle:
    """The face ``face`` ("+z", "-x", ...) of an axis-aligned box with full edge lengths ``size``."""
    center, size = np.asarray(center, float), np.asarray(size, float)
    sign = 1.0 if face[0] == "+" else -1.0
    axis = _AXIS[face[1]]
    a, b = [i for i in range(3) if i != axis]
    normal = np.zeros(3)
    normal[axis] = sign
    origin = center - size / 2
    origin[axis] = center[axis] + sign * size[axis] / 2
    u, v = np.zeros(3), np.zeros(3)
    u[a], v[b] = size[a], size[b]
    return Rectangle(origin, u, v, normal)
