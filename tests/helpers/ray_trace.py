"""An independent ray trace through triangle meshes, for the geantino-path tests."""

from __future__ import annotations

import numpy as np


def mesh_path(
    o: np.ndarray, d: np.ndarray, tri: np.ndarray, *, edge: float = 0.0, merge: float = 1e-12
) -> float:
    """Path length of the ray ``o + t d`` (t > 0) in the closed mesh ``tri`` ((n, 3, 3)):
    Moeller-Trumbore hits, a hit counted within ``edge`` (barycentric) of a triangle, hits
    closer than ``merge`` mm along the ray taken as one (a ray through a shared edge), the
    crossings paired in and out."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-30
    inv = np.where(ok, 1 / np.where(ok, det, 1), 0)
    tv = o - tri[:, 0]
    u = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    w = (qv @ d) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= -edge) & (w >= -edge) & (u + w <= 1 + edge) & (t > 0)
    ts = np.sort(t[hit])
    ts = ts[np.concatenate([[True], np.diff(ts) > merge])] if len(ts) else ts
    assert len(ts) % 2 == 0
    return float(np.sum(ts[1::2] - ts[0::2]))
