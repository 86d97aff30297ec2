"""Exact distance of points to faces of a shape (plane triangles, surfaces of revolution):
what activeness and step distances measure (:mod:`score4.world.activeness`)."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from ..shapes.base import PlaneTriangles, Revolved
from ..shapes.placed import PlacedShape
from .rough_distance import _revolved_distance


def _triangles_distance(tri: np.ndarray, p: np.ndarray) -> np.ndarray:
    from ..shapes.mesh_shape import _tri_distance

    out = np.full(len(p), np.inf)
    for start in range(0, len(p), 4096):
        block = p[start : start + 4096]
        out[start : start + 4096] = _tri_distance(block, tri).min(axis=1)
    return out


def face_distance(shape, faces: tuple[str, ...], points: np.ndarray) -> np.ndarray:
    """Exact distance (mm) of world ``points`` to the union of ``faces`` of ``shape``."""
    p = np.asarray(points, float).reshape(-1, 3)
    while isinstance(shape, PlacedShape):
        p = shape.transform.inverse_apply(p)
        shape = shape.shape
    index = {shape.faces.index(f) for f in faces}
    best = np.full(len(p), np.inf)
    for patch in shape.patches:
        if patch.face not in index:
            continue
        if isinstance(patch, PlaneTriangles):
            d = _triangles_distance(np.asarray(patch.triangles, float), p)
        elif isinstance(patch, Revolved):
            d = _revolved_distance(patch, p)
        else:
            raise ConfigError(
                f"activeness: distances to a {type(patch).__name__} face of a {shape.kind} are "
                "not supported (plane faces and surfaces of revolution are)"
            )
        best = np.minimum(best, d)
    return best
