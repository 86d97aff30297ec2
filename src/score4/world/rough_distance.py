"""Distance of points to the rough surface of a flat rough layer (its patch tops).

A flat layer (:class:`score4.world.scene.RoughLayer`) tiles a face with cells; a cell holds a
patch (variant ``k``: its top mesh lifted by the layer's base thickness) or stays flat (the face
itself, z = 0 of the layer's frame). The rough surface is the union of those cell tops; the
distance of a point to it is the distance to the nearest facet, for points in the bulk under
the face and for points inside the patches alike.

Search. Each variant's facets sit in a k-d tree of their centroids (scipy); a facet is no
nearer than its centroid's distance less its circumradius. Per point, an upper bound (the
nearest centroids' facets in its own cell) limits the ball searched in each cell
of a window around the point, and every facet in the ball is measured exactly. The window is
wide enough for every point less than :attr:`RoughSurfaceDistance.exact_depth` below the
lowest level of the surface, and the result is checked against a lower bound for all cells
beyond it: exact there.

Deeper points (a ball there holds ever more facets at nearly equal distance) take the distance
to the lowest level of each cell near them: the base plane plus an offset. It is a lower bound
of the true distance, off by less than :meth:`RoughSurfaceDistance.far_error` (the distance to
each cell's lowest vertex is an upper bound), which falls as 1/depth (for pyramids of pitch p,
below p^2 / (4 depth)).

Not part of the surface here: the walls of the layer's outer patches along the face's edge
(a point within the layer's height of that edge may be nearer to them), and, on a round face,
the rim of the face beyond the cells (an empty cell counts as a flat square).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

if TYPE_CHECKING:
    from .scene import RoughLayer

#: Depth below the surface's lowest level, in units of the largest facet circumradius, down to
#: which distances are exact (a ball at depth a holds ~2 pi a / r facets of radius r).
EXACT_DEPTH_RADII = 300.0
#: Largest window half-width in cells (the window holds (2 m + 1)^2 cells).
MAX_WINDOW = 6
#: Nearest centroids whose facets give each point's first upper bound.
FIRST_GUESS = 2
#: Centroids asked for per point in the ball search (more where that many lie in the ball).
BALL_FACETS = 32


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...k,...k->...", a, b)


def _segment(p: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    d = v - u
    t = np.clip(_dot(p - u, d) / np.maximum(_dot(d, d), 1e-300), 0.0, 1.0)
    e = p - (u + t[..., None] * d)
    return np.sqrt(_dot(e, e))


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Exact distance of points ``p`` (..., 3) to triangles ``tri`` (..., 3, 3), pair by pair."""
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    n = np.cross(b - a, c - a)
    n2 = _dot(n, n)
    unit = n / np.sqrt(np.maximum(n2, 1e-300))[..., None]
    h = _dot(p - a, unit)
    q = p - h[..., None] * unit
    inside = np.broadcast_to(n2 > 0, h.shape).copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= _dot(np.cross(v - u, q - u), n) >= 0
    edges = np.minimum(np.minimum(_segment(p, a, b), _segment(p, b, c)), _segment(p, c, a))
    return np.where(inside, np.abs(h), edges)


def _rect_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Distance of points (n, 3) to axis-aligned boxes [lo, hi] (n, 3) (0 inside)."""
    e = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt(_dot(e, e))


class _Variant:
    """One patch variant's top facets in its cell's frame (cell centre at x = y = 0), with what
    the distance of a point to a facet needs computed once: corners, edges, unit normal, the
    in-plane normals of the edges."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, lift: float) -> None:
        v = np.asarray(vertices, float) + np.array([0.0, 0.0, lift])
        self.tri = v[np.asarray(faces)]
        centroid = self.tri.mean(axis=1)
        self.radii = np.linalg.norm(self.tri - centroid[:, None], axis=2).max(axis=1)
        self.radius = float(self.radii.max())
        self.tree = cKDTree(centroid)
        self.zmin = float(v[:, 2].min())
        self.zmax = float(v[:, 2].max())
        self.low = cKDTree(v[v[:, 2] <= self.zmin + 1e-12, :2])  # the lowest vertices
        corners = [self.tri[:, 0], self.tri[:, 1], self.tri[:, 2]]
        n = np.cross(corners[1] - corners[0], corners[2] - corners[0])
        area2 = np.sqrt(_dot(n, n))
        self.flat = area2 == 0  # degenerate facets: measured by their edges only
        self.normal = n / np.where(self.flat, 1.0, area2)[:, None]
        self.edges = [corners[(e + 1) % 3] - corners[e] for e in range(3)]
        self.inv_len2 = [1.0 / np.maximum(_dot(d, d), 1e-300) for d in self.edges]
        self.inward = [np.cross(self.normal, d) for d in self.edges]  # in-plane, into the facet
        self.corners = corners

    def distance(self, p: np.ndarray, facet: np.ndarray) -> np.ndarray:
        """Exact distance of points ``p`` (n, 3) to facets ``facet`` (n,), pair by pair."""
        w = [p - c[facet] for c in self.corners]
        inside = ~self.flat[facet]
        for e in range(3):
            inside &= _dot(w[e], self.inward[e][facet]) >= 0
        out = np.abs(_dot(w[0], self.normal[facet]))
        rows = np.flatnonzero(~inside)
        if len(rows):
            f = facet[rows]
            best = np.full(len(rows), np.inf)
            for e in range(3):
                d, we = self.edges[e][f], w[e][rows]
                t = np.clip(_dot(we, d) * self.inv_len2[e][f], 0.0, 1.0)
                x = we - t[:, None] * d
                best = np.minimum(best, _dot(x, x))
            out[rows] = np.sqrt(best)
        return out


class RoughSurfaceDistance:
    """Distances of world points to the rough surface of a flat ``layer`` (mm)."""

    def __init__(self, layer: RoughLayer) -> None:
        self.frame = layer.frame
        base = layer.base_thickness
        self.variants = [
            _Variant(s.top_mesh.vertices, s.top_mesh.faces, base) for s in layer.variants
        ]
        self.cells = np.asarray(layer.cell_variants)  # (ny, nx), -1: flat
        self.ny, self.nx = self.cells.shape
        self.px, self.py = layer.patch_size
        self.cx, self.cy = layer.patch_map.cell_centre_axes()
        used = [self.variants[k] for k in np.unique(self.cells[self.cells >= 0])]
        self.zlo = min([v.zmin for v in used] + ([0.0] if (self.cells < 0).any() else []))
        self.zhi = max([v.zmax for v in used] + [0.0])
        radius = max(v.radius for v in used)
        #: depth below the lowest level of the surface down to which distances are exact, mm
        self.exact_depth = EXACT_DEPTH_RADII * radius
        # the lateral reach of the nearest surface point from a point at that depth
        height = self.zhi - self.zlo
        reach = np.sqrt(2 * self.exact_depth * height + height**2) + 2 * radius
        self.window = int(min(MAX_WINDOW, 1 + np.ceil(reach / min(self.px, self.py))))

    # --- helpers ---------------------------------------------------------------------------

    def _cell_of(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lx, ly = self.nx * self.px, self.ny * self.py
        i = np.clip(np.floor((q[:, 0] + lx / 2) / self.px), 0, self.nx - 1).astype(np.int64)
        j = np.clip(np.floor((q[:, 1] + ly / 2) / self.py), 0, self.ny - 1).astype(np.int64)
        return i, j

    def _offsets(self, m: int) -> list[tuple[int, int]]:
        pairs = [(di, dj) for di in range(-m, m + 1) for dj in range(-m, m + 1)]
        return sorted(pairs, key=lambda o: (max(abs(o[0]), abs(o[1])), abs(o[0]) + abs(o[1])))

    def _cell_box(self, q, i, j, level: str) -> tuple[np.ndarray, np.ndarray]:
        """Per point, the box of cell (i, j): its rectangle times [lowest, highest] of its
        surface (``level`` 'low': flattened to the lowest)."""
        k = self.cells[j, i]
        zmin = np.array([v.zmin for v in self.variants] + [0.0])[k]
        zmax = np.array([v.zmax for v in self.variants] + [0.0])[k]
        lo = np.column_stack([self.cx[i] - self.px / 2, self.cy[j] - self.py / 2, zmin])
        hi = np.column_stack(
            [self.cx[i] + self.px / 2, self.cy[j] + self.py / 2, zmin if level == "low" else zmax]
        )
        return lo, hi

    def _beyond(self, q: np.ndarray, i0: np.ndarray, j0: np.ndarray, m: int) -> np.ndarray:
        """A lower bound of the distance to every cell outside the window of half-width ``m``."""
        lx, ly = self.nx * self.px, self.ny * self.py
        rho = np.full(len(q), np.inf)
        left, right = i0 - m, i0 + m
        down, up = j0 - m, j0 + m
        rho = np.where(left > 0, np.minimum(rho, q[:, 0] - (-lx / 2 + left * self.px)), rho)
        rho = np.where(
            right < self.nx - 1, np.minimum(rho, (-lx / 2 + (right + 1) * self.px) - q[:, 0]), rho
        )
        rho = np.where(down > 0, np.minimum(rho, q[:, 1] - (-ly / 2 + down * self.py)), rho)
        rho = np.where(
            up < self.ny - 1, np.minimum(rho, (-ly / 2 + (up + 1) * self.py) - q[:, 1]), rho
        )
        below = np.maximum(self.zlo - q[:, 2], 0.0)
        return np.sqrt(np.maximum(rho, 0.0) ** 2 + below**2)

    def _cells_near(self, q, i0, j0, m):
        """(offset rows, cell i, cell j) of every window cell inside the face, nearest first."""
        for di, dj in self._offsets(m):
            i, j = i0 + di, j0 + dj
            ok = (i >= 0) & (i < self.nx) & (j >= 0) & (j < self.ny)
            rows = np.flatnonzero(ok)
            if len(rows):
                yield rows, i[rows], j[rows]

    # --- distances -------------------------------------------------------------------------

    def local(self, world: np.ndarray) -> np.ndarray:
        """World points in the layer's frame (z along the face's outward normal, 0 on the face)."""
        return self.frame.to_local(np.asarray(world, float).reshape(-1, 3))

    def __call__(self, world: np.ndarray) -> np.ndarray:
        """Distance (mm) of world points to the rough surface."""
        q = self.local(world)
        out = np.empty(len(q))
        deep = q[:, 2] < self.zlo - self.exact_depth
        out[~deep] = self._exact(q[~deep])
        out[deep] = self._far(q[deep])[0]
        return out

    def _exact(self, q: np.ndarray) -> np.ndarray:
        if not len(q):
            return np.empty(0)
        i0, j0 = self._cell_of(q)
        best = np.full(len(q), np.inf)
        # first guess: the facets of the nearest centroids in the point's own cell
        for rows, i, j in self._cells_near(q, i0, j0, 0):
            self._measure(q, rows, i, j, best, ball=False)
        m = self.window
        for rows, i, j in self._cells_near(q, i0, j0, m):
            lo, hi = self._cell_box(q[rows], i, j, "full")
            near = _rect_distance(q[rows], lo, hi) < best[rows]
            self._measure(q, rows[near], i[near], j[near], best, ball=True)
        return best

    def _measure(self, q, rows, i, j, best, ball: bool) -> None:
        """Lower ``best[rows]`` by the distance to cell (i, j)'s surface: the nearest centroids'
        facets (``ball`` False) or every facet that can be nearer than ``best`` (True)."""
        if not len(rows):
            return
        k = self.cells[j, i]
        flat = k < 0
        if flat.any():  # an empty cell: the flat face, z = 0
            r = rows[flat]
            lo = np.column_stack([self.cx[i[flat]] - self.px / 2, self.cy[j[flat]] - self.py / 2])
            hi = lo + np.array([self.px, self.py])
            e = np.maximum(np.maximum(lo - q[r, :2], q[r, :2] - hi), 0.0)
            best[r] = np.minimum(best[r], np.sqrt(_dot(e, e) + q[r, 2] ** 2))
        for kv in np.unique(k[~flat]):
            sel = k == kv
            r = rows[sel]
            variant = self.variants[int(kv)]
            p = q[r] - np.column_stack([self.cx[i[sel]], self.cy[j[sel]], np.zeros(len(r))])
            if not ball:
                n = min(FIRST_GUESS, len(variant.tri))
                _, idx = variant.tree.query(p, k=n)
                idx = np.asarray(idx).reshape(len(r), n)
                d = variant.distance(np.repeat(p, n, axis=0), idx.ravel())
                best[r] = np.minimum(best[r], d.reshape(len(r), n).min(axis=1))
                continue
            self._ball(variant, p, r, best)

    def _ball(self, variant: _Variant, p: np.ndarray, r: np.ndarray, best: np.ndarray) -> None:
        """Lower ``best[r]`` by every facet of ``variant`` that can be nearer to points ``p``
        than it: centroids within best + the largest facet radius, less each facet's radius."""
        n_facets = len(variant.tri)
        todo = np.arange(len(r))
        k = BALL_FACETS
        while len(todo):
            k = min(k, n_facets)
            bound = best[r[todo]] + variant.radius
            dist, idx = variant.tree.query(
                p[todo], k=k, distance_upper_bound=float(np.nextafter(bound.max(), np.inf))
            )
            dist, idx = (
                np.asarray(dist).reshape(len(todo), k),
                np.asarray(idx).reshape(len(todo), k),
            )
            found = (idx < n_facets) & (dist <= bound[:, None])
            owner, col = np.nonzero(found)
            facet = idx[owner, col]
            near = dist[owner, col] - variant.radii[facet] < best[r[todo[owner]]]
            owner, facet = owner[near], facet[near]
            if len(owner):
                got = np.full(len(todo), np.inf)
                np.minimum.at(got, owner, variant.distance(p[todo[owner]], facet))
                best[r[todo]] = np.minimum(best[r[todo]], got)
            if k == n_facets:
                break
            todo = todo[found[:, -1]]  # k facets within the bound: there may be more
            k *= 4

    def _far(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points deep under the surface: (lower bound, upper bound) of the distance; the lower
        is the distance to each near cell's lowest level (the base plane plus an offset)."""
        lower = np.full(len(q), np.inf)
        upper = np.full(len(q), np.inf)
        if not len(q):
            return lower, upper
        i0, j0 = self._cell_of(q)
        m = self.window
        for rows, i, j in self._cells_near(q, i0, j0, m):
            lo, hi = self._cell_box(q[rows], i, j, "low")
            lower[rows] = np.minimum(lower[rows], _rect_distance(q[rows], lo, hi))
            k = self.cells[j, i]
            bound = _rect_distance(q[rows], lo, hi)  # empty cells: exact
            for kv in np.unique(k[k >= 0]):
                sel = k == kv
                variant = self.variants[int(kv)]
                xy = q[rows[sel], :2] - np.column_stack([self.cx[i[sel]], self.cy[j[sel]]])
                rho, _ = variant.low.query(xy)
                bound[sel] = np.hypot(rho, q[rows[sel], 2] - variant.zmin)
            upper[rows] = np.minimum(upper[rows], bound)
        lower = np.minimum(lower, self._beyond(q, i0, j0, m))
        return lower, upper

    def far_error(self, world: np.ndarray) -> np.ndarray:
        """Per point, how far the distance returned may lie below the true one (0 where it is
        exact: points less than :attr:`exact_depth` below the surface)."""
        q = self.local(world)
        out = np.zeros(len(q))
        deep = q[:, 2] < self.zlo - self.exact_depth
        lower, upper = self._far(q[deep])
        out[deep] = upper - lower
        return out
