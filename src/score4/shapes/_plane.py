"""Plane (2-D) geometry the solids are built from: contours in the (r, z) half-plane.

A *contour* is a simple polygon given as (k, 2) corners ``(r, z)``. Helpers here reduce it the
way Geant4 does (duplicate and collinear corners removed), orient it counter-clockwise (r to the
right, z up: the outward normal of edge ``a -> b`` is ``(dz, -dr) / L``), start it at a fixed
corner, triangulate it (ear clipping), and give signed distances of points to it.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

#: Geant4's surface tolerance kCarTolerance, mm; a point within half of it from a surface is on it.
TOLERANCE = 1e-9


def signed_area(poly: np.ndarray) -> float:
    """Shoelace area of a closed polygon (positive when counter-clockwise)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def reduce_contour(poly: np.ndarray, tol: float = TOLERANCE) -> np.ndarray:
    """Drop repeated corners and corners on a straight line between their neighbours."""
    pts = list(np.asarray(poly, float))
    changed = True
    while changed and len(pts) > 3:
        changed = False
        for i in range(len(pts)):
            prev, cur, nxt = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
            a, b = cur - prev, nxt - cur
            la, lb = np.hypot(*a), np.hypot(*b)
            if la <= tol or lb <= tol or abs(_cross2(a, b)) <= tol * max(la, lb):
                if la > tol and lb > tol and np.dot(a, b) < 0:
                    continue  # a spike that turns back: leave it for the validity check
                del pts[i]
                changed = True
                break
    return np.array(pts)


def canonical_contour(r: np.ndarray, z: np.ndarray, what: str) -> np.ndarray:
    """The reduced, counter-clockwise contour starting at its lowest corner (smallest r first).

    Raises ConfigError for negative radii, fewer than three corners, zero area or an edge
    crossing another (the rules Geant4 applies to G4GenericPolycone).
    """
    poly = np.column_stack([np.asarray(r, float), np.asarray(z, float)])
    if poly.ndim != 2 or len(poly) < 3 or not np.isfinite(poly).all():
        raise ConfigError(f"{what}: need at least 3 finite (r, z) corners, got {len(poly)}")
    if (poly[:, 0] < 0).any():
        raise ConfigError(f"{what}: radii must be >= 0, got {poly[:, 0].min():g}")
    poly = reduce_contour(poly)
    if len(poly) < 3 or abs(signed_area(poly)) <= TOLERANCE:
        raise ConfigError(f"{what}: the (r, z) contour encloses no area")
    if signed_area(poly) < 0:
        poly = poly[::-1]
    if _self_crossing(poly):
        raise ConfigError(f"{what}: the (r, z) contour crosses itself")
    start = int(np.lexsort((poly[:, 0], poly[:, 1]))[0])
    return np.roll(poly, -start, axis=0)


def _self_crossing(poly: np.ndarray) -> bool:
    """True if two non-adjacent edges of the closed polygon intersect."""
    n = len(poly)
    a, b = poly, np.roll(poly, -1, axis=0)
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            d1, d2 = b[i] - a[i], b[j] - a[j]
            den = _cross2(d1, d2)
            if abs(den) < 1e-300:
                continue
            w = a[j] - a[i]
            s, t = _cross2(w, d2) / den, _cross2(w, d1) / den
            if 1e-12 < s < 1 - 1e-12 and 1e-12 < t < 1 - 1e-12:
                return True
    return False


def triangulate(poly: np.ndarray) -> np.ndarray:
    """Ear-clipping triangulation of a simple counter-clockwise polygon: (k - 2, 3, 2) triangles."""
    idx = list(range(len(poly)))
    tris = []
    guard = 0
    while len(idx) > 3 and guard < 10 * len(poly) ** 2:
        guard += 1
        for k in range(len(idx)):
            i0, i1, i2 = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            a, b, c = poly[i0], poly[i1], poly[i2]
            if _cross2(b - a, c - b) <= 0:
                continue  # reflex (or flat) corner: not an ear
            others = [poly[j] for j in idx if j not in (i0, i1, i2)]
            if others and _in_triangle(np.array(others), a, b, c).any():
                continue
            tris.append((a, b, c))
            del idx[k]
            break
        else:  # only flat corners left (numerically): cut one anyway
            i0, i1, i2 = idx[-1], idx[0], idx[1]
            tris.append((poly[i0], poly[i1], poly[i2]))
            del idx[0]
    tris.append(tuple(poly[j] for j in idx))
    out = np.array(tris, float)
    keep = np.abs(_cross2(out[:, 1] - out[:, 0], out[:, 2] - out[:, 0])) > 0
    return out[keep]


def _in_triangle(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Points inside or on the triangle (a, b, c) (counter-clockwise)."""
    d1 = _cross2(b - a, p - a)
    d2 = _cross2(c - b, p - b)
    d3 = _cross2(a - c, p - c)
    return (d1 >= 0) & (d2 >= 0) & (d3 >= 0)


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(n, m) distances of points p (n, 2) to segments a[j] -> b[j] (m, 2)."""
    d = b - a
    len2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    w = p[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nmk,mk->nm", w, d) / len2, 0.0, 1.0)
    q = w - t[..., None] * d[None]
    return np.sqrt(np.einsum("nmk,nmk->nm", q, q))


def inside_polygon(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule: True for points p (n, 2) strictly inside the closed polygon."""
    a, b = poly, np.roll(poly, -1, axis=0)
    py = p[:, 1:2]
    straddle = (a[None, :, 1] > py) != (b[None, :, 1] > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = a[None, :, 0] + (py - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (
            b[None, :, 1] - a[None, :, 1]
        )
    return (straddle & (p[:, 0:1] < x_at)).sum(axis=1) % 2 == 1


def signed_distance(p: np.ndarray, poly: np.ndarray, surface: np.ndarray) -> np.ndarray:
    """Signed distance (negative inside) of points p (n, 2) to the edges of ``poly`` that are
    surfaces (``surface[j]`` for edge j -> j+1); the sign comes from the whole polygon."""
    a, b = poly, np.roll(poly, -1, axis=0)
    dist = segment_distance(p, a[surface], b[surface]).min(axis=1)
    return np.where(inside_polygon(p, poly), -dist, dist)


def first_moment_r(poly: np.ndarray) -> float:
    """Integral of r over the polygon (r the first coordinate): Pappus' volume / (2 pi)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    return float(np.sum((x + xn) * (x * yn - xn * y)) / 6.0)
