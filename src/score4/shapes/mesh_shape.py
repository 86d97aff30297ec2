"""A closed triangle mesh as a shape (G4TessellatedSolid, G4ExtrudedSolid, or any triangulation).

For a tessellated solid the mesh *is* the solid's surface, so areas, volume and sampling are
exact. A bare mesh is one face, ``mesh``; facets may be grouped into named faces with
``facet_faces``. The mesh of a G4TessellatedSolid or G4ExtrudedSolid (:meth:`MeshShape.by_planes`)
has one face per plane (its coplanar facets): ``plane_<i>`` for a tessellated solid, ``-z``,
``+z`` and ``side_<i>`` for an extruded one, numbered in the order of the solid's facets, with
the group ``mesh`` for them all (and ``sides`` for an extruded solid's sides); a mesh of more
than :data:`MAX_NAMED_PLANES` planes (a curved surface cut into facets) stays one face ``mesh``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError
from .base import Patch, PlaneTriangles, Shape, as_points

#: A mesh of more planes than this keeps one face, ``mesh`` (:meth:`MeshShape.by_planes`).
MAX_NAMED_PLANES = 100


def plane_index(triangles: np.ndarray) -> np.ndarray:
    """(m,) the plane of each triangle (m, 3, 3): triangles with the same outward normal and
    offset (to 1e-8 of the mesh's size) share one, numbered in order of first appearance;
    degenerate triangles (no normal) get -1."""
    tri = np.asarray(triangles, float).reshape(-1, 3, 3)
    out = np.full(len(tri), -1, np.int64)
    if len(tri) == 0:
        return out
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    keep = np.flatnonzero(norm > 0)
    if len(keep) == 0:
        return out
    n = n[keep] / norm[keep, None]
    scale = max(float(np.abs(tri).max()), 1.0)
    offset = np.einsum("ij,ij->i", n, tri[keep, 0]) / scale
    key = np.round(np.column_stack([n, offset]) * 1e8).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    out[keep] = rank[inverse.ravel()]
    return out


def _tri_distance(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(n, m) exact distances of points (n, 3) to triangles (m, 3, 3)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n2 = np.einsum("ij,ij->i", n, n)
    has_area = n2 > 0  # a triangle of no area (two corners alike): measured by its edges only
    n2 = np.maximum(n2, 1e-300)
    w = p[:, None, :] - a[None]
    h = np.einsum("nmk,mk->nm", w, n) / np.sqrt(n2)
    # barycentric test of the projection
    q = p[:, None, :] - h[..., None] * (n / np.sqrt(n2)[:, None])[None]
    inside = np.broadcast_to(has_area, h.shape).copy()
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("nmk,mk->nm", np.cross(v - u, q - u[None]), n) >= 0
    best = np.where(inside, np.abs(h), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        d = v - u
        t = np.clip(
            np.einsum("nmk,mk->nm", p[:, None, :] - u[None], d)
            / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300),
            0,
            1,
        )
        e = p[:, None, :] - (u[None] + t[..., None] * d[None])
        best = np.minimum(best, np.sqrt(np.einsum("nmk,nmk->nm", e, e)))
    return best


#: A vector of arrays by components: a tuple of three, or rows of a (3, k) array.
_Vec = tuple[np.ndarray, ...] | np.ndarray


def _dot(u: _Vec, v: _Vec) -> np.ndarray:
    """Dot products of vectors given by components, summed in the order numpy's ``einsum``
    sums three terms (first and last, then the middle one): :func:`_tri_distance`'s numbers."""
    return (u[0] * v[0] + u[2] * v[2]) + u[1] * v[1]


def _cross3(u: _Vec, v: _Vec) -> tuple[np.ndarray, ...]:
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def _facet_terms(tri: np.ndarray) -> np.ndarray:
    """(20, m) per facet what :func:`_pair_distance` reads: its corners, normal, unit normal,
    the length of its normal and its squared edge lengths, in :func:`_tri_distance`'s
    arithmetic."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = np.cross(b - a, c - a)
    n2 = np.einsum("ij,ij->i", n, n)
    area = (n2 > 0).astype(float)
    root = np.sqrt(np.maximum(n2, 1e-300))
    unit = n / root[:, None]
    lengths = [
        np.maximum(np.einsum("ij,ij->i", v - u, v - u), 1e-300) for u, v in ((a, b), (b, c), (c, a))
    ]
    return np.vstack([a.T, b.T, c.T, n.T, unit.T, root, area, *lengths])


def _pair_distance(p: np.ndarray, terms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact distances of points (k, 3) to facets (k columns of :func:`_facet_terms`), pair by
    pair, in the same arithmetic as :func:`_tri_distance` (the same numbers, component by
    component); the signed distance of each point from its facet's plane (> 0 on the side its
    normal points to); and whether the pair's nearest point is inside the facet, clear of its
    edges (the plane's distance the least, by far more than rounding)."""
    t = terms
    a, b, c, n, unit = t[0:3], t[3:6], t[6:9], t[9:12], t[12:15]
    root, has_area, lengths = t[15], t[16] > 0, t[17:20]
    px, py, pz = p[:, 0], p[:, 1], p[:, 2]
    pv = (px, py, pz)
    h = _dot((px - a[0], py - a[1], pz - a[2]), n) / root
    q = (px - h * unit[0], py - h * unit[1], pz - h * unit[2])
    inside = has_area.copy()
    for u, v in ((a, b), (b, c), (c, a)):
        edge = (v[0] - u[0], v[1] - u[1], v[2] - u[2])
        inside &= _dot(_cross3(edge, (q[0] - u[0], q[1] - u[1], q[2] - u[2])), n) >= 0
    face = np.where(inside, np.abs(h), np.inf)
    near = np.full(len(p), np.inf)
    for (u, v), length in zip(((a, b), (b, c), (c, a)), lengths, strict=True):
        d = (v[0] - u[0], v[1] - u[1], v[2] - u[2])
        s = np.clip(_dot((px - u[0], py - u[1], pz - u[2]), d) / length, 0, 1)
        e = tuple(pv[k] - (u[k] + s * d[k]) for k in range(3))
        near = np.minimum(near, np.sqrt(_dot(e, e)))
    best = np.minimum(face, near)
    # clear of the edges: the nearest point of an edge is further than the plane's by a margin
    # far above rounding (then the point's side of the plane is its side of the mesh)
    clear = inside & (near - face > 1e-9 * (1.0 + near))
    return best, h, clear


def _crossing(
    tri: np.ndarray, index: np.ndarray, changed: np.ndarray, eps: float
) -> tuple[int, int] | None:
    """The first pair ``(a, b)`` of facets of a mesh (``tri`` (m, 3, 3), vertex ``index``
    (m, 3)), ``a`` among ``changed``, that share no vertex and where an edge of one crosses the
    other (further than ``eps`` mm from its ends and edges); None if there is none."""
    edges = [(0, 1), (1, 2), (2, 0)]
    for a in changed:
        others = np.flatnonzero(~np.isin(index, index[a]).any(axis=1))
        if len(others) == 0:
            continue
        for first, second in ((tri[a][None], tri[others]), (tri[others], tri[a][None])):
            for i, j in edges:
                o, d = first[:, i], first[:, j] - first[:, i]
                hits = _segment_hits(o, d, second, eps)  # one row per other facet
                if hits.any():
                    return int(a), int(others[int(np.argmax(hits))])
    return None


def _segment_hits(o: np.ndarray, d: np.ndarray, tri: np.ndarray, eps: float) -> np.ndarray:
    """Whether the segments o + s d (0 < s < 1) cross the triangles ``tri`` inside, both more
    than ``eps`` mm from their ends and edges (broadcast over rows)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-300
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    w = o - tri[:, 0]
    u = np.einsum("ij,ij->i", w, p) * inv
    q = np.cross(w, e1)
    v = np.einsum("ij,ij->i", d, q) * inv
    s = np.einsum("ij,ij->i", e2, q) * inv
    size = np.maximum(np.linalg.norm(e1, axis=1) + np.linalg.norm(e2, axis=1), 1e-300)
    along = eps / np.maximum(np.linalg.norm(d, axis=1), 1e-300)
    rel = eps / size
    return ok & (u > rel) & (v > rel) & (u + v < 1 - rel) & (s > along) & (s < 1 - along)


def _winding(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Generalised winding number of a closed, outward-oriented mesh around points (n,)."""
    a = tri[None, :, 0] - p[:, None]
    b = tri[None, :, 1] - p[:, None]
    c = tri[None, :, 2] - p[:, None]
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    num = np.einsum("nmk,nmk->nm", a, np.cross(b, c))
    den = (
        la * lb * lc
        + np.einsum("nmk,nmk->nm", a, b) * lc
        + np.einsum("nmk,nmk->nm", b, c) * la
        + np.einsum("nmk,nmk->nm", c, a) * lb
    )
    return np.arctan2(num, den).sum(axis=1) / (2 * np.pi)


@dataclass(frozen=True, eq=False)
class MeshShape(Shape):
    """A closed triangle mesh, facets wound counter-clockwise seen from outside.

    Parameters
    ----------
    triangles
        (m, 3, 3) facet corners, mm.
    facet_faces
        Optional (m,) face index per facet into ``face_names``.
    face_names
        Names of the faces (default: one face, ``mesh``).
    """

    triangles: np.ndarray
    facet_faces: np.ndarray | None = None
    face_names: tuple[str, ...] = ("mesh",)
    face_groups: tuple[tuple[str, tuple[str, ...]], ...] = ()
    kind = "MeshShape"
    _chunk: int = field(default=4_000_000, repr=False)

    def __post_init__(self) -> None:
        tri = np.asarray(self.triangles, float)
        if tri.ndim != 3 or tri.shape[1:] != (3, 3) or len(tri) < 4:
            raise ConfigError(f"MeshShape: need (m >= 4, 3, 3) triangles, got {tri.shape}")
        object.__setattr__(self, "triangles", tri)
        ff = (
            np.zeros(len(tri), np.int64)
            if self.facet_faces is None
            else np.asarray(self.facet_faces, np.int64)
        )
        if ff.shape != (len(tri),) or ff.min() < 0 or ff.max() >= len(self.face_names):
            raise ConfigError("MeshShape: facet_faces must index face_names, one per facet")
        object.__setattr__(self, "facet_faces", ff)
        object.__setattr__(self, "face_names", tuple(self.face_names))
        groups = tuple((str(g), tuple(f)) for g, f in self.face_groups)
        if any(g in self.face_names or not set(f) <= set(self.face_names) for g, f in groups):
            raise ConfigError("MeshShape: face_groups must name groups of face_names")
        object.__setattr__(self, "face_groups", groups)

    @classmethod
    def by_planes(cls, triangles: np.ndarray, extruded: bool = False) -> MeshShape:
        """The mesh of a G4TessellatedSolid (``extruded``: a G4ExtrudedSolid) with one face
        per plane (see the module docstring); one face ``mesh`` beyond
        :data:`MAX_NAMED_PLANES` planes. Degenerate facets join the first plane."""
        tri = np.asarray(triangles, float).reshape(-1, 3, 3)
        plane = plane_index(tri)
        count = int(plane.max()) + 1
        if count <= 1 or count > MAX_NAMED_PLANES:
            return cls(tri)
        plane[plane < 0] = 0
        names = [f"plane_{i}" for i in range(count)]
        groups: list[tuple[str, tuple[str, ...]]] = []
        if extruded:
            z = tri[..., 2]
            lo, hi = float(z.min()), float(z.max())
            tol = 1e-9 * max(float(np.abs(tri).max()), 1.0)
            n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            ends: dict[int, str] = {}
            for i in range(count):
                rows = plane == i
                nz = n[rows][0, 2] / max(float(np.linalg.norm(n[rows][0])), 1e-300)
                if nz < -1 + 1e-12 and np.all(np.abs(z[rows] - lo) <= tol):
                    ends[i] = "-z"
                elif nz > 1 - 1e-12 and np.all(np.abs(z[rows] - hi) <= tol):
                    ends[i] = "+z"
            sides = [i for i in range(count) if i not in ends]
            for k, i in enumerate(sides):
                names[i] = f"side_{k}"
            for i, end in ends.items():
                names[i] = end
            groups.append(("sides", tuple(names[i] for i in sides)))
        groups.insert(0, ("mesh", tuple(names)))
        return cls(tri, plane, tuple(names), tuple(groups))

    def _build(self):
        tri = self.triangles
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(normal, axis=1, keepdims=True)
        normal = np.divide(normal, norm, out=np.zeros_like(normal), where=norm > 0)
        patches: list[Patch] = []
        assert self.facet_faces is not None
        for k in range(len(self.face_names)):
            rows = np.flatnonzero(self.facet_faces == k)
            if len(rows):
                patches.append(PlaneTriangles(k, tri[rows], normal[rows]))
        return self.face_names, dict(self.face_groups), patches

    def moved(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """The mesh with each named face moved inward by ``cuts[face]`` mm (< 0: outward; a
        face of several planes, each of its planes), its other planes kept: each vertex of a
        moved face goes where its planes meet again (the least move that does it: along the
        normal inside the face, along the neighbour's plane on an edge), the same shift (0) of
        the origin (kept per ``cuts``: a face of several planes takes a layer per plane, each
        asking for the same move). None for a face with a facet of no area. ConfigError,
        naming the face and why, where the moved mesh would not be a valid solid: a corner of
        the face on more other planes than meet the moved plane in one point, a facet turned
        over or shrunk to a sliver, or a moved facet crossing another part of the mesh."""
        if not cuts or set(cuts) - set(self.face_names):
            return None
        key = tuple(sorted(cuts.items()))
        if key not in self._moved:
            self._moved[key] = self._move(cuts)
        return self._moved[key]

    @cached_property
    def _moved(self) -> dict[tuple[tuple[str, float], ...], tuple[Shape, np.ndarray] | None]:
        return {}

    def _move(self, cuts: dict[str, float]) -> tuple[Shape, np.ndarray] | None:
        """:meth:`moved`, not kept."""
        tri = self.triangles
        plane = plane_index(tri)
        assert self.facet_faces is not None
        moving: dict[int, float] = {}
        for name, depth in cuts.items():
            found = set(plane[self.facet_faces == self.face_names.index(name)].tolist())
            if not found or -1 in found:
                return None
            for p in found:  # a face of several planes (a curved surface cut into facets,
                moving[p] = float(depth)  # one face ``mesh``): every plane moves by it
        count = int(plane.max()) + 1
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        verts, index = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
        index = index.reshape(-1, 3)
        unit = np.zeros((count, 3))
        for p in range(count):
            unit[p] = normal[np.argmax(plane == p)]
        scale = max(float(np.abs(verts).max()), 1.0)
        what = ", ".join(f"{k} by {-v * 1e3:.4g} um" for k, v in cuts.items())
        what = f"{self.kind}: face {what} outward" if len(cuts) == 1 else f"{self.kind}: {what}"
        new = verts.copy()
        touched = np.unique(index[np.isin(plane, list(moving))])
        for v in touched:
            planes = np.unique(plane[(index == v).any(axis=1) & (plane >= 0)])
            a = unit[planes]
            b = np.array([-moving.get(int(p), 0.0) for p in planes])
            step = np.linalg.lstsq(a, b, rcond=None)[0]
            if np.abs(a @ step - b).max() > 1e-9 * scale:
                raise ConfigError(
                    f"{what}: its corner ({', '.join(f'{x:.6g}' for x in verts[v])}) mm joins "
                    f"{len(planes) - 1} other planes, which the moved plane does not meet in one "
                    "point; score4 moves a mesh face only where each corner lies on at most two "
                    "other planes (or on planes through one line)"
                )
            new[v] = verts[v] + step
        out = new[index]
        changed = np.isin(index, touched).any(axis=1)
        m = np.cross(out[:, 1] - out[:, 0], out[:, 2] - out[:, 0])
        area = np.linalg.norm(m, axis=1)
        longest = np.max(
            [np.linalg.norm(out[:, (k + 1) % 3] - out[:, k], axis=1) for k in range(3)], axis=0
        )
        flat = ~(np.einsum("ij,ij->i", m, normal) > 0) | (area / np.maximum(longest, 1e-300) < 1e-8)
        if (flat & changed).any():
            k = int(np.flatnonzero(flat & changed)[0])
            raise ConfigError(
                f"{what}: facet {k} (of face {self.face_names[self.facet_faces[k]]}) would turn "
                "over or shrink to a sliver (the face's neighbour is narrower than the move); "
                "the move must be thinner than the solid there"
            )
        hit = _crossing(out, index, np.flatnonzero(changed), 1e-9 * scale)
        if hit is not None:
            k = hit[1]
            raise ConfigError(
                f"{what}: the moved facets would cross facet {k} (of face "
                f"{self.face_names[self.facet_faces[k]]}) of the same solid, which lies closer "
                "to the face than the move; the move must be thinner than the gap"
            )
        return replace(self, triangles=out), np.zeros(3)

    @cached_property
    def _search(self) -> tuple[np.ndarray, ...] | None:
        """What :meth:`signed_distance` prunes with: the facets' boxes (lo, hi), unit normals
        and plane offsets, the mesh's box, its size and orientation (+1 outward, -1 inward);
        None for a mesh that is not closed (an edge not met once each way by two facets) or has
        a facet of no area: those are measured against every facet. (A closed mesh is taken
        not to cross itself, as the surface of a solid.)"""
        tri = self.triangles
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        norm = np.linalg.norm(n, axis=1)
        verts, index = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
        index = index.reshape(-1, 3)
        edges = np.concatenate([index[:, [0, 1]], index[:, [1, 2]], index[:, [2, 0]]])
        code = edges[:, 0] * len(verts) + edges[:, 1]
        back = edges[:, 1] * len(verts) + edges[:, 0]
        closed = (
            (norm > 0).all()
            and (edges[:, 0] != edges[:, 1]).all()
            and len(np.unique(code)) == len(code)
            and np.isin(back, code).all()
        )
        if not closed or self.volume == 0:
            return None
        unit = n / norm[:, None]
        offset = np.einsum("ij,ij->i", unit, tri[:, 0])
        scale = np.array([max(float(np.abs(tri).max()), 1.0), 1.0 if self.volume > 0 else -1.0])
        lo, hi = self.bounding_box()
        return (
            tri.min(axis=1).T,
            tri.max(axis=1).T,
            unit.T,
            offset,
            lo,
            hi,
            scale,
            _facet_terms(tri),
        )

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        """The distance to the nearest facet (exact), negative where the winding number of the
        mesh around the point is above 1/2 in size. For a closed mesh only the facets that can
        be nearest are measured (their boxes and planes against the distance to the likeliest
        one), and the side is read from the nearest facet's plane where the nearest point lies
        inside it, clear of its edges, or where the point is outside the mesh's box; the
        winding number is summed only for the other points (near an edge or corner, or within
        1e-10 of the mesh's size of it). The same numbers as measuring every facet."""
        p = as_points(points)
        search = self._search
        out = np.empty(len(p))
        step = max(1, self._chunk // len(self.triangles))
        if search is not None:
            step = min(step, 4096)  # pairs a few times that: arrays that stay in the cache
        for s in range(0, len(p), step):
            q = p[s : s + step]
            if search is None:
                dist = _tri_distance(q, self.triangles).min(axis=1)
                inside = np.abs(_winding(q, self.triangles)) > 0.5
            else:
                dist, inside = self._nearest(q, search)
            out[s : s + step] = np.where(inside, -dist, dist)
        return out

    def _nearest(self, q: np.ndarray, search: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
        """(distance, inside) of points ``q`` (n, 3) of :meth:`signed_distance`, closed mesh."""
        tlo, thi, unit, offset, lo, hi, (scale, orient), terms = search
        tri = self.triangles
        slack = 1e-9 * scale
        # a lower bound of each point's distance to each facet (squared): to its box, to its plane
        gap = np.zeros((len(q), len(tri)))
        for k in range(3):
            x = q[:, k : k + 1]
            g = np.maximum(np.maximum(tlo[k] - x, x - thi[k]), 0.0)
            gap += g * g
        plane = q @ unit - offset
        bound = np.maximum(gap, plane * plane)
        first = np.argmin(bound, axis=1)
        reach = _pair_distance(q, terms[:, first])[0] + slack
        near = bound <= (reach * reach)[:, None]
        near[np.arange(len(q)), first] = True
        rows, cols = np.nonzero(near)
        best, h, clear = _pair_distance(q[rows], terms[:, cols])
        starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
        dist = np.minimum.reduceat(best, starts)
        # per point, its nearest pair (the first of equals)
        at = np.flatnonzero(best == dist[rows])
        pick = at[np.r_[True, rows[at][1:] != rows[at][:-1]]]
        far = ((q < lo - slack) | (q > hi + slack)).any(axis=1)
        known = far | (clear[pick] & (dist > 1e-10 * scale))
        inside = ~far & (orient * h[pick] < 0)
        rest = np.flatnonzero(~known)
        if len(rest):
            inside[rest] = np.abs(_winding(q[rest], tri)) > 0.5
        return dist, inside

    @property
    def volume(self) -> float:
        t = self.triangles
        return float(np.einsum("ij,ij->", t[:, 0], np.cross(t[:, 1], t[:, 2])) / 6.0)

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        flat = self.triangles.reshape(-1, 3)
        return flat.min(axis=0), flat.max(axis=0)

    def to_dict(self) -> dict[str, Any]:
        assert self.facet_faces is not None
        return {
            "type": self.kind,
            "triangles": self.triangles.tolist(),
            "facet_faces": self.facet_faces.tolist(),
            "face_names": list(self.face_names),
            "face_groups": [[g, list(f)] for g, f in self.face_groups],
        }
