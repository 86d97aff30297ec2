r"""Vertices below a rough surface: depth definitions, exact distances, the vertex sampler.

Depth profiles live in :mod:`score4.source.profiles`; this module places vertices with them.

Depth definitions
-----------------
``normal`` (as in the SCoRe4 paper)
    A surface point ``p`` is drawn uniformly per true area, a depth ``d`` from the profile,
    and the vertex is ``x = p - d n(p)``, ``n`` the outward facet normal. Under ridges (where
    the material is a wedge) the inward prisms of neighbouring facets overlap and vertices end
    up closer than ``d`` to the surface; under valleys the inward normals diverge and a wedge
    of material receives no vertex at all.

``distance`` (new)
    The vertex's true distance to the surface equals the drawn depth: ``dist(x, S) = d``.
    Given ``d``, ``x`` is uniform per unit area on the level set
    ``L_d = {x in the material : dist(x, S) = d}``. Consequences:

    * the histogram of true distances is exactly the profile, as on a flat face;
    * the vertex density per unit volume at ``x`` is ``N f(delta) / |L_delta|`` with
      ``delta = dist(x, S)``: the contamination per unit depth is what came in through the
      surface, spread over the level set, so it is diluted under valleys (``L_delta`` is
      larger than the surface there) and concentrated under ridges;
    * on a flat face ``normal`` and ``distance`` are identical.

    Exact construction. ``L_d`` is covered by disjoint pieces: the facets translated by
    ``-d n`` (area ``A_F``); for every *valley* edge (the material is reflex there) a cylinder
    sector of radius ``d``, opening ``theta_e`` = angle between the two facet normals and
    length ``L_e`` (area ``theta_e d L_e``); for every vertex whose cone of closest-point
    directions lies in the material, the part of the sphere of radius ``d`` in that cone
    (proposed from an enclosing cap of solid angle ``Omega_v``). A proposal chooses a piece
    with probability proportional to ``A``, ``d theta L`` or ``d^2 Omega``, a point uniformly
    on it, and is accepted iff no triangle is closer than ``d`` (exact point-triangle
    distances, :class:`MeshDistance`). The depth is kept while the point is redrawn, so the
    accepted point is uniform on ``L_d`` and ``d`` keeps its law. A vertex the confinement
    rejects is redrawn with a new depth (exact conditioning on the confinement).

    Border conventions: an open mesh border continues as the extension of its border facets
    (border edges and vertices add no pieces). With ``period`` the mesh is one tile of a
    periodic surface: border vertices are identified across the period and distances include
    the neighbouring images. On a tiled face every variant is treated as periodic with the
    cell pitch: exact for one variant, an approximation within ``d`` of cell borders between
    different variants.

Analytic V-groove check (used by the tests)
    Valley ``z = s|x|`` (``|x| <= W``, ``0 <= y <= Y``), material below, ``r = sqrt(1 + s^2)``.
    The inward normals ``(+-s, 0, -1)/r`` diverge, so facet pieces never overlap and the
    valley edge adds a sector of opening ``theta = 2 atan(s)``:
    ``|L_d| = 2 W r Y + theta d Y``. With ``distance`` a vertex lies in the wedge below the
    valley (closest surface point on the valley line) with probability
    ``theta d / (2 W r + theta d)``; with ``normal`` never. Ridge ``z = -s|x|``: with
    ``normal`` the vertex drawn at ``|x_s|`` crosses the symmetry plane, and is then closer
    than ``d`` to the other facet, iff ``|x_s| < d s / r``, i.e. with probability
    ``min(1, d s / (W r))``; with ``distance`` never.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from .profiles import DepthProfile, check_window
from .sampling import (
    DiscreteSampler,
    SurfaceSampler,
    TiledSurfaceSampler,
    orthonormal_basis,
    triangle_areas,
    triangle_normals,
)

__all__ = [
    "MeshDistance",
    "OffsetSurface",
    "VertexSampler",
    "Vertices",
    "closest_points_on_triangles",
]

DepthDefinition = Literal["normal", "distance"]
Confinement = Callable[[np.ndarray], np.ndarray]


# --------------------------------------------------------------------------------------------
# Exact point-to-mesh distances
# --------------------------------------------------------------------------------------------


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", u, v)


def _closest_st(
    d1: np.ndarray, d2: np.ndarray, ab2: np.ndarray, ac2: np.ndarray, abac: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates ``(s, t)`` of the closest point ``a + s ab + t ac`` of a triangle to ``p``.

    ``d1 = ab . (p - a)``, ``d2 = ac . (p - a)``; ``ab2``, ``ac2``, ``abac`` are the triangle's
    Gram entries. ``p`` is classified into the Voronoi regions of the vertices, edges and face
    by the signs of barycentric dot products (the other four dot products follow from these).
    """
    d3, d4 = d1 - ab2, d2 - abac  # ab . (p - b), ac . (p - b)
    d5, d6 = d1 - abac, d2 - ac2  # ab . (p - c), ac . (p - c)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        den = 1.0 / (va + vb + vc)
    regions = [
        (d1 <= 0) & (d2 <= 0),  # vertex a
        (d3 >= 0) & (d4 <= d3),  # vertex b
        (d6 >= 0) & (d5 <= d6),  # vertex c
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),  # edge ab
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),  # edge ac
        (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),  # edge bc
    ]
    s = np.select(regions, [0.0, 1.0, 0.0, t_ab, 0.0, 1.0 - t_bc], vb * den)
    t = np.select(regions, [0.0, 0.0, 1.0, 0.0, t_ac, t_bc], vc * den)
    return s, t


def closest_points_on_triangles(
    p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
) -> np.ndarray:
    """Closest point of triangle ``(a[i], b[i], c[i])`` to ``p[i]``, all arrays (k, 3).

    Exact and vectorised; triangles must not be degenerate.
    """
    ab, ac, ap = b - a, c - a, p - a
    s, t = _closest_st(_dot(ab, ap), _dot(ac, ap), _dot(ab, ab), _dot(ac, ac), _dot(ab, ac))
    return a + s[:, None] * ab + t[:, None] * ac


def _flatten_lists(lists: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths and concatenation of the index lists returned by ``query_ball_point``."""
    lengths = np.fromiter(map(len, lists), dtype=np.intp, count=len(lists))
    flat = np.fromiter(
        itertools.chain.from_iterable(lists), dtype=np.intp, count=int(lengths.sum())
    )
    return lengths, flat


class MeshDistance:
    """Exact unsigned distances from points to a triangle set, with a spatial index.

    Triangles are grouped by size (circumradius about the centroid, powers of two); each
    group has a k-d tree of centroids, so a triangle within ``r`` of a point has its centroid
    within ``r + R_group`` of it. Candidates are then measured exactly
    (:func:`closest_points_on_triangles`).

    Parameters
    ----------
    triangles
        (m, 3, 3) non-degenerate triangles.
    period
        Optional (px, py): the triangles are one tile of a surface periodic in x and y;
        distances then include the eight neighbouring images.
    chunk
        Points handled per batch (bounds the memory of candidate lists).
    brute_max
        Size groups with at most this many triangles are searched by testing every pair
        (cheaper than a tree query that returns most of them anyway).

    Notes
    -----
    The cost per query grows with the number of triangles within the query radius, i.e.
    with (depth / triangle size)^2 when depths exceed the triangle size.
    """

    def __init__(
        self,
        triangles: np.ndarray,
        period: tuple[float, float] | None = None,
        chunk: int = 16384,
        brute_max: int = 64,
    ) -> None:
        from scipy.spatial import cKDTree

        tri = np.asarray(triangles, dtype=float)
        self._a = np.ascontiguousarray(tri[:, 0])
        self._ab = np.ascontiguousarray(tri[:, 1] - tri[:, 0])
        self._ac = np.ascontiguousarray(tri[:, 2] - tri[:, 0])
        self._gram = np.stack(
            [_dot(self._ab, self._ab), _dot(self._ac, self._ac), _dot(self._ab, self._ac)], axis=1
        )
        self._normal = triangle_normals(tri)
        centroid = tri.mean(axis=1)
        radius = np.linalg.norm(tri - centroid[:, None], axis=2).max(axis=1)
        self._groups = []
        scale = np.floor(np.log2(np.maximum(radius, radius.max() * 2.0**-40)))
        for level in np.unique(scale):
            members = np.flatnonzero(scale == level)
            self._groups.append((members, cKDTree(centroid[members]), float(radius[members].max())))
        self._centroid = centroid
        self._brute_max = brute_max
        self._rmax = float(radius.max())
        self._lo, self._hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        self._images = np.zeros((1, 3))
        if period is not None:
            px, py = period
            shifts = [(i * px, j * py, 0.0) for i in (0, -1, 1) for j in (0, -1, 1)]
            self._images = np.array(shifts)
        self._chunk = chunk

    def _pairs(
        self, points: np.ndarray, radius: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Candidate (point, triangle, image) triples, the triangle possibly within ``radius``."""
        pi, tj, oi = [], [], []
        for o, off in enumerate(self._images):
            y = (
                points - off
            )  # distance to (triangle + off) == distance of (point - off) to triangle
            reach = (radius + self._rmax)[:, None]
            sel = np.flatnonzero(((y >= self._lo - reach) & (y <= self._hi + reach)).all(axis=1))
            if len(sel) == 0:
                continue
            for members, tree, rg in self._groups:
                if len(members) <= self._brute_max:
                    p, t = self._all_pairs(y[sel], radius[sel] + rg, members)
                    p = sel[p]
                else:
                    lengths, flat = _flatten_lists(tree.query_ball_point(y[sel], radius[sel] + rg))
                    p, t = np.repeat(sel, lengths), members[flat]
                pi.append(p)
                tj.append(t)
                oi.append(np.full(len(t), o))
        if not pi:
            return (np.zeros(0, np.intp),) * 3
        return np.concatenate(pi), np.concatenate(tj), np.concatenate(oi)

    def _all_pairs(
        self, y: np.ndarray, reach: np.ndarray, members: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point row, triangle) with the centroid within ``reach`` (dense test)."""
        gap = y[:, None, :] - self._centroid[members][None, :, :]
        p, k = np.nonzero(np.einsum("ijk,ijk->ij", gap, gap) <= (reach * reach)[:, None])
        return p, members[k]

    def _pair_distance(
        self,
        points: np.ndarray,
        pi: np.ndarray,
        tj: np.ndarray,
        oi: np.ndarray,
        below: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Exact distances of candidate pairs. With ``below`` (per point), pairs whose plane
        distance (a lower bound) is already >= ``below`` are dropped first; returns the kept
        pair rows and their distances."""
        ap = points[pi] - self._images[oi] - self._a[tj]
        rows = np.arange(len(pi))
        if below is not None:
            rows = np.flatnonzero(np.abs(_dot(ap, self._normal[tj])) < below[pi])
            ap, tj = ap[rows], tj[rows]
        ab, ac = self._ab[tj], self._ac[tj]
        gram = self._gram[tj]
        s, t = _closest_st(_dot(ab, ap), _dot(ac, ap), gram[:, 0], gram[:, 1], gram[:, 2])
        return rows, np.linalg.norm(ap - s[:, None] * ab - t[:, None] * ac, axis=1)

    def _upper_bound(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance to, and index of, the best nearest-centroid triangle (over images
        and size groups): an upper bound of the distance to the mesh."""
        ub, best = np.full(len(points), np.inf), np.zeros(len(points), dtype=np.int64)
        every = np.arange(len(points))
        for o in range(len(self._images)):
            for members, tree, _ in self._groups:
                tj = members[tree.query(points - self._images[o], k=1)[1]]
                dd = self._pair_distance(points, every, tj, np.full(len(points), o))[1]
                better = dd < ub
                ub[better], best[better] = dd[better], tj[better]
        return ub, best

    def distance(self, points: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance of each point to the mesh and the index of a nearest triangle."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        dist, index = np.empty(len(points)), np.empty(len(points), dtype=np.int64)
        for start in range(0, len(points), self._chunk):
            p = points[start : start + self._chunk]
            ub, best = self._upper_bound(p)
            reach = ub * (1 + 1e-9) + 1e-300
            pi, tj, oi = self._pairs(p, reach)
            rows, dd = self._pair_distance(p, pi, tj, oi, below=reach)
            pi, tj = pi[rows], tj[rows]
            order = np.lexsort((dd, pi))  # per point, nearest candidate first
            first = order[np.r_[True, pi[order][1:] != pi[order][:-1]]]
            closer = dd[first] < ub[pi[first]]
            ub[pi[first][closer]], best[pi[first][closer]] = dd[first][closer], tj[first][closer]
            dist[start : start + len(p)], index[start : start + len(p)] = ub, best
        return dist, index

    def any_within(self, points: ArrayLike, radius: ArrayLike) -> np.ndarray:
        """True where some triangle is strictly closer than ``radius`` to the point."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        radius = np.broadcast_to(np.asarray(radius, dtype=float), (len(points),))
        hit = np.zeros(len(points), dtype=bool)
        for start in range(0, len(points), self._chunk):
            p, r = points[start : start + self._chunk], radius[start : start + self._chunk]
            live = np.flatnonzero(r > 0)
            pi, tj, oi = self._pairs(p[live], r[live])
            rows, dd = self._pair_distance(p[live], pi, tj, oi, below=r[live])
            hit[start + live[pi[rows][dd < r[live][pi[rows]]]]] = True
        return hit


# --------------------------------------------------------------------------------------------
# Level sets of the distance: the exact sampler behind the 'distance' definition
# --------------------------------------------------------------------------------------------


def _weld(tri: np.ndarray, period: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    """Shared vertex ids (m, 3), matching coordinates to 1e-9 of the mesh size (modulo period),
    and the rounding step (3,) used for that."""
    pts = tri.reshape(-1, 3)
    extent = float(np.ptp(pts, axis=0).max()) or 1.0
    step = np.full(3, 1e-9 * extent)
    if period is not None:  # make each period an integer number of steps, so x and x + p weld
        per = np.asarray(period, dtype=float)
        step[:2] = per / np.round(per / step[:2])
    keys = np.round(pts / step).astype(np.int64)
    if period is not None:
        keys[:, :2] %= np.round(np.asarray(period) / step[:2]).astype(np.int64)
    return _group_rows(keys).reshape(-1, 3), step


def _group_rows(keys: np.ndarray) -> np.ndarray:
    """Group ids (0..g-1) of equal rows of an integer array (n, k); faster than unique(axis=0)."""
    order = np.lexsort(keys.T[::-1])
    ordered = keys[order]
    new = np.r_[True, (ordered[1:] != ordered[:-1]).any(axis=1)]
    ids = np.empty(len(keys), dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids


@dataclass
class _Edges:
    """Face-edge occurrences (flat index ``face * 3 + k``: corner k to corner k + 1) grouped
    into mesh edges."""

    start: np.ndarray  # (3m,) vertex id where each occurrence starts
    end: np.ndarray  # (3m,) vertex id where it ends
    vec: np.ndarray  # (3m, 3) its vector, from the face's own coordinates
    first: np.ndarray  # (e,) one occurrence of each mesh edge
    second: np.ndarray  # (e,) the other occurrence, -1 on the border
    boundary_vertices: np.ndarray  # vertex ids on border edges


def _mesh_edges(tri: np.ndarray, ids: np.ndarray, step: np.ndarray, periodic: bool) -> _Edges:
    """Group the 3m face edges into mesh edges; reject non-manifold or inconsistent meshes.

    An edge is identified by its end ids; on a periodic mesh also by its vector, since two
    vertices can then be joined by several edges (through different images), and an edge
    spanning a whole period joins a vertex to itself.
    """
    start, end = ids.ravel(), ids[:, [1, 2, 0]].ravel()
    vec = (tri[:, [1, 2, 0]] - tri).reshape(-1, 3)
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    if periodic:
        key_vec = np.round(vec / step).astype(np.int64)
        flip = (start > end) | ((start == end) & _negative_first(key_vec))
        key_vec[flip] *= -1  # the same edge seen from both faces gets the same key
        inverse = _group_rows(np.c_[lo, hi, key_vec])
    else:
        inverse = np.unique(lo * (int(ids.max()) + 1) + hi, return_inverse=True)[1]
    counts = np.bincount(inverse)
    if (counts > 2).any():
        raise ConfigError(
            f"triangles: {int((counts > 2).sum())} edges are shared by more than two faces; "
            "depth 'distance' needs a manifold surface mesh"
        )
    order = np.argsort(inverse, kind="stable")
    first_pos = np.searchsorted(inverse[order], np.arange(len(counts)))
    first = order[first_pos]
    second = np.where(counts == 2, order[np.minimum(first_pos + 1, len(order) - 1)], -1)
    pair = second >= 0
    if (_dot(vec[first[pair]], vec[second[pair]]) > 0).any():
        raise ConfigError(
            "triangles: neighbouring faces are wound in opposite senses; normals must all point "
            "outward"
        )
    border = first[~pair]
    return _Edges(
        start, end, vec, first, second, np.unique(np.concatenate([start[border], end[border]]))
    )


def _negative_first(v: np.ndarray) -> np.ndarray:
    """True where the first non-zero component of integer vectors ``v`` is negative."""
    nonzero = v != 0
    first = np.argmax(nonzero, axis=1)
    return v[np.arange(len(v)), first] < 0


class OffsetSurface:
    """Uniform points on the level sets ``{x in material : dist(x, S) = d}`` of a triangle mesh.

    See the module docstring for the construction. Coordinates are those of the triangles
    (patch-local for tiled faces).

    Parameters
    ----------
    triangles
        (m, 3, 3) consistently wound triangles (outward normals); zero-area ones are ignored.
    facet_ids
        Optional (m,) ids reported instead of triangle indices.
    period
        Optional (px, py) period in x, y (the mesh is one tile of a periodic surface).
    """

    def __init__(
        self,
        triangles: np.ndarray,
        facet_ids: np.ndarray | None = None,
        period: tuple[float, float] | None = None,
    ) -> None:
        tri = np.asarray(triangles, dtype=float)
        areas = triangle_areas(tri)
        keep = np.flatnonzero(areas > 1e-14 * areas.max())
        self._facet_of = keep if facet_ids is None else np.asarray(facet_ids)[keep]
        tri = tri[keep]
        self._facets = SurfaceSampler(tri)
        self.area = self._facets.area
        ids, step = _weld(tri, period)
        edges = _mesh_edges(tri, ids, step, period is not None)
        self._setup_edges(tri, edges)
        self._setup_cones(tri, ids, edges)
        self._last_kind = (
            2 if self._cone_choice is not None else 1 if self._edge_choice is not None else 0
        )
        self._distance = MeshDistance(tri, period)
        self._tol = 1e-12 * max(
            float(np.abs(tri).max()), float(np.ptp(tri.reshape(-1, 3), axis=0).max())
        )

    @property
    def n_valley_edges(self) -> int:
        """Number of valley edges (each adds a cylinder sector to the level sets)."""
        return len(self._edge_theta)

    @property
    def n_vertex_cones(self) -> int:
        """Number of vertices whose closest-point cone lies in the material."""
        return len(self._cone_cos)

    # -- set-up ------------------------------------------------------------------------------

    def _setup_edges(self, tri: np.ndarray, edges: _Edges) -> None:
        """Valley edges: the material is reflex there, so a cylinder sector belongs to L_d."""
        pair = edges.second >= 0
        o1, o2 = edges.first[pair], edges.second[pair]
        f1, k1, f2, k2 = o1 // 3, o1 % 3, o2 // 3, o2 % 3
        q0, q1 = tri[f1, k1], tri[f1, (k1 + 1) % 3]
        n1, n2 = self._facets.normals[f1], self._facets.normals[f2]
        rise = tri[f2, (k2 + 2) % 3] - tri[f2, k2]  # from the edge to the far corner of face 2
        up = _dot(rise, n1) / np.linalg.norm(rise, axis=1)
        valley = np.flatnonzero(up > 1e-9)
        n1, n2, cos = n1[valley], n2[valley], _dot(n1[valley], n2[valley])
        theta = np.arctan2(np.linalg.norm(np.cross(n1, n2), axis=1), cos)
        toward = -n2 + cos[:, None] * n1  # the part of -n2 orthogonal to n1
        self._edge_start = q0[valley]
        self._edge_vec = q1[valley] - q0[valley]
        self._edge_a = -n1
        self._edge_b = toward / np.linalg.norm(toward, axis=1, keepdims=True)
        self._edge_theta = theta
        self._edge_face = f1[valley]
        weight = theta * np.linalg.norm(self._edge_vec, axis=1)
        self.edge_weight = float(weight.sum())  # area of the edge pieces per unit depth
        self._edge_choice = (
            DiscreteSampler(weight, "edge weights") if self.edge_weight > 0 else None
        )

    def _setup_cones(self, tri: np.ndarray, ids: np.ndarray, edges: _Edges) -> None:
        """Vertices whose cone of closest-point directions has volume and lies in the material."""
        start, corners = edges.start, tri.reshape(-1, 3)
        occ = edges.first  # one occurrence per mesh edge gives its vector, both directions
        vertex = np.concatenate([edges.start[occ], edges.end[occ]])
        vectors = np.concatenate([edges.vec[occ], -edges.vec[occ]])
        interior = ~np.isin(vertex, edges.boundary_vertices)
        vertex, vectors = vertex[interior], vectors[interior]
        vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
        pseudo = self._pseudo_normals(tri, ids)
        first_corner = np.unique(start, return_index=True)[1]
        order = np.argsort(vertex, kind="stable")
        vertex, vectors = vertex[order], vectors[order]
        uniq, begin, degree = np.unique(vertex, return_index=True, return_counts=True)
        found = [
            self._cones_of_degree(uniq, begin, degree, vectors, pseudo, deg)
            for deg in np.unique(degree)
        ]
        found = [f for f in found if len(f[0])]
        dmax = max((f[2].shape[1] for f in found), default=1)
        vid = np.concatenate([f[0] for f in found]) if found else np.zeros(0, np.int64)
        self._cone_center = np.concatenate([f[1] for f in found]) if found else np.zeros((0, 3))
        self._cone_edges = (
            np.concatenate(
                [np.pad(f[2], ((0, 0), (0, dmax - f[2].shape[1]), (0, 0))) for f in found]
            )
            if found
            else np.zeros((0, 1, 3))
        )
        self._cone_cos = np.concatenate([f[3] for f in found]) if found else np.zeros(0)
        self._cone_pos = corners[first_corner[vid]]
        self._cone_face = first_corner[vid] // 3
        if len(vid):
            self._cone_e1, self._cone_e2 = orthonormal_basis(self._cone_center)
        omega = 2 * np.pi * (1 - self._cone_cos)
        self.vertex_weight = float(omega.sum())  # area of the vertex pieces per unit depth^2
        self._cone_choice = DiscreteSampler(omega, "vertex cones") if len(vid) else None

    @staticmethod
    def _pseudo_normals(tri: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """Angle-weighted vertex normals: their sign separates material from vacuum at vertices."""
        normals = triangle_normals(tri)
        pseudo = np.zeros((int(ids.max()) + 1, 3))
        for k in range(3):
            u = tri[:, (k + 1) % 3] - tri[:, k]
            v = tri[:, (k + 2) % 3] - tri[:, k]
            angle = np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), _dot(u, v))
            for axis in range(3):
                pseudo[:, axis] += np.bincount(
                    ids[:, k], angle * normals[:, axis], minlength=len(pseudo)
                )
        return pseudo

    @staticmethod
    def _cones_of_degree(
        uniq: np.ndarray,
        begin: np.ndarray,
        degree: np.ndarray,
        vectors: np.ndarray,
        pseudo: np.ndarray,
        deg: int,
        chunk: int = 8192,
    ) -> tuple[np.ndarray, ...]:
        """Cones {u : u . e <= 0 for all incident edges e} of the vertices with ``deg`` edges.

        Extreme rays are the feasible +-(e_i x e_j): ``+`` is feasible iff every
        det(e_i, e_j, e_k) <= 0, ``-`` iff every one is >= 0. A cone is kept when its rays span
        3-D and it lies on the material side (centre . pseudo-normal < 0). Returns vertex ids,
        centres, incident unit edges and the cosine of an enclosing cap.
        """
        out: tuple[list, ...] = ([], [], [], [])
        i, j = np.triu_indices(deg, 1)
        rows = np.flatnonzero(degree == deg)
        for s in range(0, len(rows), chunk):
            r = rows[s : s + chunk]
            e = vectors[begin[r][:, None] + np.arange(deg)]  # (v, deg, 3)
            # two opposite edges (a straight line through v) confine the cone to a plane
            r = r[(np.einsum("vpk,vpk->vp", e[:, i], e[:, j]) > -1 + 1e-12).all(axis=1)]
            e = vectors[begin[r][:, None] + np.arange(deg)]
            cross = np.cross(e[:, i], e[:, j])  # (v, pairs, 3)
            norm = np.linalg.norm(cross, axis=2)
            det = np.matmul(cross, e.transpose(0, 2, 1))  # (v, pairs, deg)
            tol = 1e-9 * norm
            valid = norm > 1e-9
            plus = valid & (det.max(axis=2) <= tol)
            minus = valid & (det.min(axis=2) >= -tol)
            unit = cross / np.maximum(norm, 1e-300)[..., None]
            sign = plus.astype(float) - minus  # +1, -1, or 0 (both would mean a flat star)
            total = (unit * sign[..., None]).sum(axis=1)
            size = np.linalg.norm(total, axis=1)
            weight = (plus | minus).astype(float)
            ev = np.linalg.eigvalsh(np.einsum("vp,vpk,vpl->vkl", weight, unit, unit))
            solid = (size > 1e-9) & (ev[:, 0] > 1e-12 * np.maximum(ev[:, 2], 1e-300))
            center = total / np.maximum(size, 1e-300)[:, None]
            material = _dot(center, pseudo[uniq[r]]) < 0
            keep = np.flatnonzero(solid & material)
            along = np.einsum("vpk,vk->vp", unit[keep], center[keep])
            cos_plus = np.where(plus[keep], along, 2.0).min(axis=1)
            cos_minus = np.where(minus[keep], -along, 2.0).min(axis=1)
            cosmax = np.minimum(cos_plus, cos_minus)
            cosmax = np.where(cosmax < 0.05, -1.0, cosmax)  # wide cones: propose the whole sphere
            for lst, val in zip(out, (uniq[r][keep], center[keep], e[keep], cosmax), strict=True):
                lst.append(val)
        return tuple(np.concatenate(v) if v else np.zeros((0,)) for v in out)

    # -- sampling ----------------------------------------------------------------------------

    def weight(self, d: ArrayLike) -> np.ndarray:
        """Total proposal area at depth ``d``: ``A + d sum(theta L) + d^2 sum(Omega)``."""
        d = np.asarray(d, dtype=float)
        return self.area + d * self.edge_weight + d * d * self.vertex_weight

    def propose(
        self, rng: np.random.Generator, d: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One proposal per depth; returns points, outward normals at the closest surface point,
        facet ids and the acceptance mask (point on the level set ``L_d``)."""
        n = len(d)
        r = rng.random(n) * self.weight(d)
        kind = (r >= self.area).astype(np.int8) + (r >= self.area + d * self.edge_weight)
        kind = np.minimum(
            kind, self._last_kind
        )  # r == total by rounding must not pick a missing piece
        x, normal = np.empty((n, 3)), np.empty((n, 3))
        facet, ok = np.empty(n, dtype=np.int64), np.ones(n, dtype=bool)
        rows = np.flatnonzero(kind == 0)
        idx = self._facets.sample_index(rng, len(rows))
        normal[rows] = self._facets.normals[idx]
        x[rows] = self._facets.points_in(rng, idx) - d[rows, None] * normal[rows]
        facet[rows] = idx
        rows = np.flatnonzero(kind == 1)
        if len(rows):
            x[rows], normal[rows], facet[rows] = self._propose_edges(rng, d[rows])
        rows = np.flatnonzero(kind == 2)
        if len(rows):
            x[rows], normal[rows], facet[rows], ok[rows] = self._propose_cones(rng, d[rows])
        test = np.flatnonzero(ok & (d > 0))
        ok[test] = ~self._distance.any_within(x[test], d[test] * (1 - 1e-9) - self._tol)
        return x, normal, self._facet_of[facet], ok

    def _propose_edges(
        self, rng: np.random.Generator, d: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points on the cylinder sectors of valley edges (always on L_d up to the global test)."""
        assert self._edge_choice is not None  # proposals come only from existing edges
        e = self._edge_choice.sample(rng, len(d))
        t, phi = rng.random((2, len(d)))
        phi *= self._edge_theta[e]
        u = np.cos(phi)[:, None] * self._edge_a[e] + np.sin(phi)[:, None] * self._edge_b[e]
        q = self._edge_start[e] + t[:, None] * self._edge_vec[e]
        return q + d[:, None] * u, -u, self._edge_face[e]

    def _propose_cones(
        self, rng: np.random.Generator, d: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Points on the enclosing caps of vertex cones; the mask says which fell in the cone."""
        assert self._cone_choice is not None  # proposals come only from existing cones
        v = self._cone_choice.sample(rng, len(d))
        s, phi = rng.random((2, len(d)))
        cos = 1 - s * (1 - self._cone_cos[v])  # uniform on the cap
        sin = np.sqrt(np.maximum(1 - cos * cos, 0.0))
        phi *= 2 * np.pi
        u = (
            cos[:, None] * self._cone_center[v]
            + (sin * np.cos(phi))[:, None] * self._cone_e1[v]
            + (sin * np.sin(phi))[:, None] * self._cone_e2[v]
        )
        inside = np.einsum("vdk,vk->vd", self._cone_edges[v], u).max(axis=1) <= 0
        return self._cone_pos[v] + d[:, None] * u, -u, self._cone_face[v], inside

    def distance(self, points: ArrayLike) -> np.ndarray:
        """Exact distance of points to this surface (images included when periodic)."""
        return self._distance.distance(points)[0]


# --------------------------------------------------------------------------------------------
# Vertices below the surface
# --------------------------------------------------------------------------------------------


@dataclass
class Vertices:
    """Decay vertices below a surface.

    Attributes
    ----------
    position
        (n, 3) vertex positions in mm (world coordinates).
    normal
        (n, 3) unit outward surface normal at the surface point the vertex belongs to (for
        ``distance``: at its closest surface point, also on edges and vertices).
    depth
        (n,) depth in mm (shift along the normal, or true distance to the surface).
    facet
        (n,) triangle index or id of that surface point (an incident facet on edges/vertices).
    patch, variant
        (n,) cell index and variant on a tiled face, else None.
    face
        (n,) face index of the surface point on a sampler over several faces of a volume
        (:class:`~score4.source.shape_sampling.ShapeSurfaceSampler`), else None.
    """

    position: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    facet: np.ndarray
    patch: np.ndarray | None = None
    variant: np.ndarray | None = None
    face: np.ndarray | None = None


def _has_mesh(sampler: object) -> bool:
    return isinstance(sampler, (SurfaceSampler, TiledSurfaceSampler))


def _mesh_distance(sampler: SurfaceSampler | TiledSurfaceSampler, x: np.ndarray) -> np.ndarray:
    """Unsigned distances of world points to a sampler's mesh (NaN off a tiled face's patches);
    the distance structures are built once per sampler and kept on it."""
    cache = sampler.__dict__.setdefault("_mesh_distances", {})
    if isinstance(sampler, SurfaceSampler):
        if "all" not in cache:
            cache["all"] = MeshDistance(sampler.triangles)
        return cache["all"].distance(x)[0]
    px, py = sampler.pitch
    local = (x - sampler.origin) @ sampler.rotation
    i = np.floor(local[:, 0] / px).astype(np.int64)
    j = np.floor(local[:, 1] / py).astype(np.int64)
    nx, ny = sampler.shape
    inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    variant = np.full(len(x), -1, np.int64)
    variant[inside] = sampler.layout[i[inside], j[inside]]
    out = np.full(len(x), np.nan)
    for k, v in enumerate(sampler.variants):
        rows = np.flatnonzero(variant == k)
        if len(rows):
            if k not in cache:
                cache[k] = MeshDistance(v.triangles, period=sampler.pitch)
            offset = np.stack([i[rows] * px, j[rows] * py, np.zeros(len(rows))], axis=1)
            out[rows] = cache[k].distance(local[rows] - offset)[0]
    return out


class _SingleLayout:
    """A plain triangle set seen as a 1 x 1 tiling, so both cases share one code path."""

    def __init__(self, sampler: SurfaceSampler) -> None:
        self.variants = [sampler]
        self.cell_counts = np.array([1])
        self.rotation = np.eye(3)

    def sample_cells(self, rng: np.random.Generator, variant: np.ndarray) -> np.ndarray:
        return np.zeros(len(variant), dtype=np.int64)

    def to_world(self, local: np.ndarray, patch: np.ndarray) -> np.ndarray:
        return local


class VertexSampler:
    """Draws decay vertices: a surface point per true area, a depth, a definition, constraints.

    Parameters
    ----------
    surface
        A :class:`SurfaceSampler` (one triangle set), a :class:`TiledSurfaceSampler`, or a
        sampler with its own ``draw_vertices(rng, depths, definition)`` hook such as
        :class:`~score4.source.shape_sampling.ShapeSurfaceSampler` (faces of any volume).
    profile
        The depth profile.
    definition
        ``"normal"`` or ``"distance"`` (see the module docstring).
    min_depth, max_depth
        Depth window in mm; the profile is truncated to it exactly.
    inside
        Optional confinement ``inside(points (k, 3)) -> (k,) bool`` in world coordinates;
        vertices outside are redrawn (surface point and depth).
    max_rounds
        Redraw rounds before giving up with a :class:`ConfigError` that counts the failures
        per constraint. No vertex that violates a constraint is ever returned.
    period
        For a single triangle set and ``distance``: (px, py) if the set is one periodic tile.
        A tiled face always uses its cell pitch.
    """

    def __init__(
        self,
        surface: SurfaceSampler | TiledSurfaceSampler,
        profile: DepthProfile,
        *,
        definition: DepthDefinition = "normal",
        min_depth: float = 0.0,
        max_depth: float = np.inf,
        inside: Confinement | None = None,
        max_rounds: int = 1000,
        period: tuple[float, float] | None = None,
    ) -> None:
        if definition not in ("normal", "distance"):
            raise ConfigError(f"definition: got {definition!r}; use 'normal' or 'distance'")
        if int(max_rounds) < 1:
            raise ConfigError(f"max_rounds: got {max_rounds!r}; must be >= 1")
        self.surface, self.definition, self.inside = surface, definition, inside
        self.min_depth, self.max_depth = check_window(min_depth, max_depth)
        self.profile = profile.truncated(self.min_depth, self.max_depth)
        self.max_rounds = int(max_rounds)
        self.offset_surfaces: list[OffsetSurface] = []  # one per variant, for 'distance'
        self._hook = getattr(surface, "draw_vertices", None)  # faces of a volume
        if self._hook is not None:
            surface.check_definition(definition)  # type: ignore[union-attr]
            self._tiled = bool(getattr(surface, "has_patches", False))
            return
        self._tiled = isinstance(surface, TiledSurfaceSampler)
        self._layout: TiledSurfaceSampler | _SingleLayout = (
            surface if isinstance(surface, TiledSurfaceSampler) else _SingleLayout(surface)
        )
        if definition == "distance":
            per = surface.pitch if isinstance(surface, TiledSurfaceSampler) else period
            self.offset_surfaces = [
                OffsetSurface(v.triangles, v.facet_ids, per) for v in self._layout.variants
            ]

    def sample(self, rng: np.random.Generator, n: int) -> Vertices:
        """``n`` vertices satisfying every constraint."""
        depth = self.profile.sample(rng, n)
        out = Vertices(np.empty((n, 3)), np.empty((n, 3)), depth, np.empty(n, dtype=np.int64))
        if self._tiled:
            out.patch, out.variant = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
        if self._hook is not None:
            out.face = np.empty(n, dtype=np.int64)
        pending = np.arange(n)
        failures = {"confinement": 0, "distance": 0}
        draw = self._draw_normal if self.definition == "normal" else self._draw_distance
        face = None
        for _ in range(self.max_rounds):
            if len(pending) == 0:
                return out
            if self._hook is not None:
                x, normal, facet, patch, variant, on_level, face = self._hook(
                    rng, depth[pending], self.definition
                )
            else:
                x, normal, facet, patch, variant, on_level = draw(rng, depth[pending])
            failures["distance"] += int((~on_level).sum())
            confined = self._confined(x, on_level)
            failures["confinement"] += int((on_level & ~confined).sum())
            good = on_level & confined
            rows = pending[good]
            out.position[rows], out.normal[rows], out.facet[rows] = (
                x[good],
                normal[good],
                facet[good],
            )
            if out.patch is not None and out.variant is not None:  # tiled faces
                out.patch[rows], out.variant[rows] = patch[good], variant[good]
            if out.face is not None and face is not None:
                out.face[rows] = face[good]
            redraw = pending[on_level & ~confined]  # confinement failures get a new depth too
            depth[redraw] = self.profile.sample(rng, len(redraw))
            pending = pending[~good]
        if len(pending) == 0:
            return out
        raise ConfigError(
            f"vertices: {len(pending)} of {n} vertices could not be placed within "
            f"max_rounds={self.max_rounds}: {failures['confinement']} draws were outside the "
            f"confinement, {failures['distance']} 'distance' proposals were closer than the drawn "
            f"depth to another part of the surface (depth window [{self.min_depth:g}, "
            f"{self.max_depth:g}] mm is sampled exactly and never fails)"
        )

    def depth_of(
        self,
        points: ArrayLike,
        anchor: ArrayLike,
        normal: ArrayLike,
        anchor_depth: ArrayLike,
        face: ArrayLike | None = None,
    ) -> np.ndarray:
        """Depths (mm) below the surface of points in the material, e.g. where a recoil moved a
        vertex: the true distance to the surface mesh (a triangle set, or the mesh of a tiled
        face, its cell's variant taken as periodic with the cell pitch, as ``distance``
        vertices are), else (flat faces of a volume, cells without patch) the depth below the
        plane through ``anchor`` (a vertex at ``anchor_depth`` below the surface point whose
        outward normal is ``normal``): ``anchor_depth + (anchor - x) . normal``. ``face``:
        the ``face`` index of each anchor on a sampler over faces of a volume.
        """
        x = np.asarray(points, dtype=float).reshape(-1, 3)
        n0 = np.asarray(normal, dtype=float).reshape(-1, 3)
        depth = np.asarray(anchor_depth, dtype=float) + np.einsum(
            "ij,ij->i", np.asarray(anchor, dtype=float).reshape(-1, 3) - x, n0
        )
        if not len(x):
            return depth
        parts: list[tuple[np.ndarray, Any]] = []
        surface: Any = self.surface  # also a ShapeSurfaceSampler (faces of a volume)
        if isinstance(surface, (SurfaceSampler, TiledSurfaceSampler)):
            parts.append((np.arange(len(x)), surface))
        elif face is not None:  # faces of a volume: the rough ones on their meshes
            face = np.asarray(face)
            for index, sampler in getattr(surface, "rough", []):
                rows = np.flatnonzero(face == index)
                meshes = [p for p in getattr(sampler, "parts", [sampler]) if _has_mesh(p)]
                parts.extend((rows, part) for part in meshes)
        for rows, sampler in parts:
            if len(rows):
                d = _mesh_distance(sampler, x[rows])
                ok = np.isfinite(d)
                depth[rows[ok]] = d[ok]
        return depth

    def _confined(self, x: np.ndarray, on_level: np.ndarray) -> np.ndarray:
        if self.inside is None:
            return np.ones(len(x), dtype=bool)
        mask = np.zeros(len(x), dtype=bool)
        rows = np.flatnonzero(on_level)
        got = np.asarray(self.inside(x[rows]))
        if got.shape != (len(rows),) or got.dtype != bool:
            raise ConfigError(
                f"inside: must return a ({len(rows)},) bool array, got {got.dtype} {got.shape}"
            )
        mask[rows] = got
        return mask

    def _draw_normal(self, rng: np.random.Generator, d: np.ndarray) -> tuple:
        """Surface points shifted by ``d`` along the inward facet normal (never rejected)."""
        s = self.surface.sample(rng, len(d))
        x = s.position - d[:, None] * s.normal
        return x, s.normal, s.facet, s.patch, s.variant, np.ones(len(d), dtype=bool)

    def _draw_distance(self, rng: np.random.Generator, d: np.ndarray) -> tuple:
        """One level-set proposal per depth, over the variants of a tiled face."""
        n, layout = len(d), self._layout
        # variant k with probability n_k W_k(d): W_k is its proposal area at this depth
        weight = np.stack(
            [
                c * o.weight(d)
                for c, o in zip(layout.cell_counts, self.offset_surfaces, strict=True)
            ],
            axis=1,
        )
        cum = np.cumsum(weight, axis=1)
        variant = np.minimum(
            (cum <= (rng.random(n) * cum[:, -1])[:, None]).sum(axis=1),
            len(self.offset_surfaces) - 1,
        )
        patch = layout.sample_cells(rng, variant)
        local, normal = np.empty((n, 3)), np.empty((n, 3))
        facet, ok = np.empty(n, dtype=np.int64), np.empty(n, dtype=bool)
        for k, offset in enumerate(self.offset_surfaces):
            rows = np.flatnonzero(variant == k)
            if len(rows):
                local[rows], normal[rows], facet[rows], ok[rows] = offset.propose(rng, d[rows])
        x = layout.to_world(local, patch)
        return x, normal @ layout.rotation.T, facet, patch, variant, ok
