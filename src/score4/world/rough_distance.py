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

from ..shapes.base import Revolved
from ..shapes.faces import RevolvedFace

if TYPE_CHECKING:
    from .scene import CurvedRoughLayer, RoughLayer

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


def _segment_distance_2d(r, z, r1, z1, r2, z2) -> np.ndarray:
    dr, dz = r2 - r1, z2 - z1
    length2 = dr * dr + dz * dz
    t = (
        np.zeros_like(r)
        if length2 == 0
        else np.clip(((r - r1) * dr + (z - z1) * dz) / length2, 0, 1)
    )
    return np.hypot(r - (r1 + t * dr), z - (z1 + t * dz))


def _segment_distance_3d(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    length2 = float(d @ d)
    t = np.zeros(len(p)) if length2 == 0 else np.clip((p - a) @ d / length2, 0, 1)
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)


def _revolved_distance(patch: Revolved, p: np.ndarray) -> np.ndarray:
    """Exact distance of points to a segment swept about z over [phi0, phi0 + dphi]."""
    r = np.hypot(p[:, 0], p[:, 1])
    d = _segment_distance_2d(r, p[:, 2], patch.r1, patch.z1, patch.r2, patch.z2)
    if patch.dphi >= 2 * np.pi - 1e-12:
        return d
    phi = np.mod(np.arctan2(p[:, 1], p[:, 0]) - patch.phi0, 2 * np.pi)
    inside = phi <= patch.dphi
    edges = []
    for angle in (patch.phi0, patch.phi0 + patch.dphi):
        c, s = np.cos(angle), np.sin(angle)
        a = np.array([patch.r1 * c, patch.r1 * s, patch.z1])
        b = np.array([patch.r2 * c, patch.r2 * s, patch.z2])
        edges.append(_segment_distance_3d(p, a, b))
    return np.where(inside, d, np.minimum(*edges))


def _rect_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Distance of points (n, 3) to axis-aligned boxes [lo, hi] (n, 3) (0 inside)."""
    e = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt(_dot(e, e))


class _Variant:
    """One patch variant's top facets in its cell's frame (cell centre at x = y = 0), with what
    the distance of a point to a facet needs computed once: corners, edges, unit normal, the
    in-plane normals of the edges."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, lift: float) -> None:
        # scipy.spatial here, not at the top: ~0.3 s CPU to import, which every Geant4 worker
        # process paid (it imports this module through geometry.built) though few measure distances
        from scipy.spatial import cKDTree

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


def _ball(variant: _Variant, p: np.ndarray, r: np.ndarray, best: np.ndarray) -> None:
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


class RoughSurfaceDistance:
    """Distances of world points to the rough surface of a flat ``layer`` (mm); with ``flat``
    False to its patch tops alone (the cells without a patch left out: for a layer whose flat
    cells reach off a boolean's face, :mod:`score4.world.rough_face_distance`)."""

    def __init__(self, layer: RoughLayer, flat: bool = True) -> None:
        self.flat = flat
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
        if flat.any() and self.flat:  # an empty cell: the flat face, z = 0
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
        _ball(variant, p, r, best)

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


class CurvedRoughSurfaceDistance:
    """Distances of world points to the rough surface of a curved ``layer`` (mm): the bent
    patch tops (:class:`score4.world.curved.BentVariant`, one facet set per variant and ring
    radius) and, in a cell without a patch, the smooth face there.

    The same search as :class:`RoughSurfaceDistance`, cell by cell in a window of rings and
    cells around the point (each point turned into the frame of each cell): the nearest
    centroids' facets give an upper bound, then every facet whose centroid lies within it plus
    the facet's radius is measured exactly. Points more than :attr:`exact_depth` under the
    lowest level of the tops take the smooth face's distance plus that level (a lower bound,
    off by less than :meth:`far_error`). With ``flat`` False: to the patch tops alone (for a
    layer on a boolean's face, :mod:`score4.world.rough_face_distance`)."""

    def __init__(self, layer: CurvedRoughLayer, flat: bool = True) -> None:
        self.layer = layer
        self.flat = flat
        lay = layer.ring_layout
        self.lay = lay
        self.cells = np.asarray(layer.cell_variants)  # (rings, columns), -1: flat
        self.px, self.py = lay.patch_size
        self.pitch = self.py + lay.row_gap
        self.full = lay.face.dphi >= 2 * np.pi - 1e-9
        self.phi = np.zeros((len(lay.v), max(int(lay.count.max()) if len(lay.v) else 0, 1)))
        for j in range(len(lay.v)):
            self.phi[j, : int(lay.count[j])] = lay.cell_phi(j)
        self.ring_key = np.array([layer.ring_solid_key(j) for j in range(len(lay.v))])
        self.ring_z = np.array([lay.ring_z(j) for j in range(len(lay.v))])
        face = lay.face
        assert isinstance(face, RevolvedFace), "sphere faces are refused by world.resolve"
        self.face_patch = Revolved(0, face.rz1, face.rz2, face.phi0, face.dphi, face.nrz)
        self._variants: dict[tuple[int, float], _Variant] = {}
        self._reach: dict[tuple[int, float], tuple[np.ndarray, float]] = {}
        offset = layer.base_thickness + layer.lift
        real = np.zeros(self.cells.shape, bool)
        for j, n in enumerate(lay.count):
            real[j, : int(n)] = True
        used = np.unique(self.cells[real & (self.cells >= 0)])
        levels = [
            (
                float(layer.variants[k].top_mesh.vertices[:, 2].min()) + offset,
                float(layer.variants[k].top_mesh.vertices[:, 2].max()) + offset,
            )
            for k in used
        ]
        empty = bool((real & (self.cells < 0)).any())
        #: lowest and highest level of the tops above the true surface (at the vertices), mm
        self.zlo = min([lo for lo, _ in levels] + ([0.0] if empty else []))
        self.zhi = max([hi for _, hi in levels] + [0.0]) + layer.top_margin
        radius = max(
            [self.variant(int(k), j).radius for k in used for j in self._rings_of(int(k))]
            or [max(self.px, self.py)]
        )
        #: depth below the lowest level of the tops down to which distances are exact, mm
        self.exact_depth = EXACT_DEPTH_RADII * radius
        height = self.zhi - self.zlo
        reach = np.sqrt(2 * self.exact_depth * height + height**2) + 2 * radius
        self.window = int(min(MAX_WINDOW, 1 + np.ceil(reach / min(self.px, self.py))))

    def _rings_of(self, k: int) -> list[int]:
        """One ring per distinct ring radius holding variant ``k``."""
        seen: dict[float, int] = {}
        for j in range(len(self.lay.v)):
            n = int(self.lay.count[j])
            if (self.cells[j, :n] == k).any():
                seen.setdefault(self.layer.ring_solid_key(j), j)
        return list(seen.values())

    def variant(self, k: int, j: int) -> _Variant:
        """Variant ``k``'s bent top facets on ring ``j`` (ring frame: cell at phi = 0)."""
        key = (k, self.layer.ring_solid_key(j))
        if key not in self._variants:
            bent = self.layer.bent(k, j)
            self._variants[key] = _Variant(bent.vertices, bent.faces[: bent.n_top], 0.0)
            v = bent.top_triangles.reshape(-1, 3)
            centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
            self._reach[key] = (centre, float(np.linalg.norm(v - centre, axis=1).max()))
        return self._variants[key]

    def local(self, world: np.ndarray) -> np.ndarray:
        """World points in the target's frame."""
        return self.layer.target.to_local(np.asarray(world, float).reshape(-1, 3))

    def __call__(self, world: np.ndarray) -> np.ndarray:
        """Distance (mm) of world points to the rough surface."""
        q = self.local(world)
        h = self.lay.face.locate(q)[2]
        out = np.empty(len(q))
        deep = h < self.zlo - self.exact_depth
        out[~deep] = self._exact(q[~deep])
        out[deep] = self._smooth(q[deep]) + self.zlo
        return out

    def far_error(self, world: np.ndarray) -> np.ndarray:
        """Per point, how far the distance returned may lie below the true one (0 where it is
        exact): the tops' height range for points deeper than :attr:`exact_depth`."""
        h = self.lay.face.locate(self.local(world))[2]
        return np.where(h < self.zlo - self.exact_depth, self.zhi - self.zlo, 0.0)

    def _smooth(self, q: np.ndarray) -> np.ndarray:
        return _revolved_distance(self.face_patch, q) if len(q) else np.empty(0)

    def _window(self, q: np.ndarray):
        """(rows, ring j, cell i, the point's own cell) of every cell of the window around each
        point."""
        lay = self.lay
        u, v, _ = lay.face.locate(q)
        rings = len(lay.v)
        if not rings:
            return
        jc = np.clip(np.floor((v - lay.v[0]) / self.pitch + 0.5), 0, rings - 1).astype(np.int64)
        m = self.window
        for dj in range(-m, m + 1):
            j = jc + dj
            ok = (j >= 0) & (j < rings)
            jj = np.where(ok, j, 0)
            step, count = lay.step[jj], lay.count[jj]
            # the azimuth from the face's middle, in (-pi, pi]; beyond the ring's ends (its
            # gap, or off a partial face) the nearest end cell
            d = np.mod(u - lay.phi_mid + np.pi, 2 * np.pi) - np.pi
            ic = np.floor((d + count * step / 2) / step).astype(np.int64)
            ic = np.clip(ic, 0, np.maximum(count - 1, 0))
            for di in range(-m, m + 1):
                i = ic + di
                if self.full:
                    i = np.mod(i, np.maximum(count, 1))
                good = ok & (i >= 0) & (i < count)
                rows = np.flatnonzero(good)
                if len(rows):
                    yield rows, j[rows], i[rows], di == 0 and dj == 0

    def _turned(self, q: np.ndarray, j: np.ndarray, i: np.ndarray) -> np.ndarray:
        """Points in the frame of cell (j, i): turned by minus its azimuth, z from its ring."""
        phi = self.phi[j, i]
        c, s = np.cos(phi), np.sin(phi)
        return np.column_stack(
            [c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1], q[:, 2] - self.ring_z[j]]
        )

    def _exact(self, q: np.ndarray) -> np.ndarray:
        best = np.full(len(q), np.inf)
        if not len(q):
            return best
        cells = list(self._window(q))
        # first guess: the own cell's nearest centroids' facets; then every cell's ball
        for rows, j, i, own in cells:
            if own:
                self._measure(q, rows, j, i, best, False)
        for rows, j, i, _ in cells:
            self._measure(q, rows, j, i, best, True)
        return best

    def _measure(self, q, rows, j, i, best, ball: bool) -> None:
        k = self.cells[j, i]
        flat = k < 0
        if flat.any() and self.flat:  # an empty cell: the smooth face's piece there
            lay, face = self.lay, self.lay.face
            assert isinstance(face, RevolvedFace)
            for a, b in {(int(a), int(b)) for a, b in zip(j[flat], i[flat], strict=True)}:
                sel = flat & (j == a) & (i == b)
                lo, hi = lay.v[a] - self.py / 2, lay.v[a] + self.py / 2
                p0, p1 = face.point(0.0, lo), face.point(0.0, hi)
                phi0 = self.phi[a, b] - lay.step[a] / 2
                patch = Revolved(0, (p0[0], p0[2]), (p1[0], p1[2]), phi0, lay.step[a], face.nrz)
                r = rows[sel]
                best[r] = np.minimum(best[r], _revolved_distance(patch, q[r]))
        keys = self.ring_key[j]
        for kv in np.unique(k[~flat]):
            for key in np.unique(keys[k == kv]):
                sel = (k == kv) & (keys == key)
                r = rows[sel]
                variant = self.variant(int(kv), int(j[sel][0]))
                p = self._turned(q[r], j[sel], i[sel])
                if not ball:
                    n = min(FIRST_GUESS, len(variant.tri))
                    _, idx = variant.tree.query(p, k=n)
                    idx = np.asarray(idx).reshape(len(r), n)
                    d = variant.distance(np.repeat(p, n, axis=0), idx.ravel())
                    best[r] = np.minimum(best[r], d.reshape(len(r), n).min(axis=1))
                    continue
                centre, reach = self._reach[(int(kv), float(key))]
                near = np.linalg.norm(p - centre, axis=1) - reach < best[r]
                _ball(variant, p[near], r[near], best)
