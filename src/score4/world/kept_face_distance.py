"""Distance of points to faces of a boolean solid as they are on the boolean: each face of a leaf
solid restricted to the part its siblings keep (:meth:`score4.shapes.BooleanShape.face_clip`),
for activeness on some of a boolean's faces (:mod:`score4.world.boolean_distance`; numpy and
scipy, no Geant4).

Why it is exact. On one patch of a leaf's face (a plane triangle, or a segment swept about z) a
point has one nearest point (the squared distance has a single local minimum there). Where that
point is kept, it is the nearest kept point. Where it is not, the nearest kept point lies on the
*rim* of the kept part: the patch's own edges where they are kept, and the curves where other
constituents cut the patch (a minimum inside the kept part would be the patch's minimum). So
the distance to the kept face is the smallest of the distances to the patches whose nearest
point is kept and the distance to the rim.

The rim, once per face. Each patch's parameter domain (a triangle's barycentric coordinates; a
swept segment's ``(t, phi)``) is cut into triangles, and those are halved in size until each is
proven kept or proven cut away by :meth:`FaceClip.margin` (a lower bound of the distance to the
rim at a point: a piece whose vertices all have margins of one sign, one of them at least the
piece's size, lies wholly on that side), or down to :data:`FINEST` mm (:data:`SAME_SIDE` for a
piece whose vertices all lie on one side). Kept pieces give the
patch's edges they lie on. A finest piece whose vertices differ gives one chord between the
points where its edges cross the rim (found by bisection). Chords are split in two, their
midpoints pushed onto the rim the same way, until each chord is within :data:`TOLERANCE` of the
rim at its midpoint (its sagitta): distances are exact to that. The chords go in k-d trees of
their midpoints, searched with a bound for the chords not visited. The kept parts of a swept
patch's end circles are joined into arcs and measured in closed form.

Where the face lies on another constituent's surface (the margin is zero over an area: two
constituents' faces flush on the outside, a part standing on the face), whether it is kept is
decided as the boolean's face sampler decides (:meth:`BooleanShape._candidates`): a hair along
the boolean's outward normal is outside the boolean and a hair against it inside. So two flush
outer faces of a union are both kept there, a post's foot on a disk is not. Margins prove
nothing there, so a piece whose vertices all lie on another surface is decided by their probe
tests only once it is no larger than :data:`FLUSH` (before, at any size: a hole in a flush
region, or the notch of a flush region that is not convex, was missed).

Not resolved: a rim feature that no vertex of the finest pieces sees (a sliver cut narrower than
:data:`FINEST`, or than :data:`SAME_SIDE` inside a piece whose vertices all lie on one side and
whose margins do not prove it, or than :data:`FLUSH` inside a flush region).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from ..errors import ConfigError
from ..shapes import BooleanShape
from ..shapes._plane import TOLERANCE as TOLERANCE_G4
from ..shapes.base import PlaneTriangles, Revolved, Shape
from ..shapes.boolean import PROBE, FaceClip
from ..shapes.placed import PlacedShape
from ..shapes.transform import Transform

#: mm: largest gap between a rim chord's midpoint and the rim (the rim is exact to this).
TOLERANCE = 1e-6
#: mm: size of the finest pieces of a face's parameter domain near the rim.
FINEST = 0.05
#: mm: a piece whose vertices are all on one side is not cut smaller than this (where the
#: margin stays small over an area, as where a face touches a cutting solid's face).
SAME_SIDE = 4 * FINEST
#: a margin this close to zero is on another constituent's surface: kept where the boolean's
#: probe test says so (:func:`kept`).
ON_SURFACE = 1e-12
#: mm: a piece whose vertices all lie on another constituent's surface is decided whole by
#: their probe test only once it is no larger than this (a flush region's holes and notches
#: narrower than this may be missed; at SAME_SIDE a post's foot of r 7 mm on a disk made its
#: rim build ~3.5x slower).
FLUSH = 1.0
#: bisection steps for a rim crossing (2^-44: 6e-14 of the parameter interval).
BISECT = 44
#: straight rim pieces are cut to at most this length (mm) so that the search bound stays tight.
PIECE = 4 * FINEST


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...k,...k->...", a, b)


def segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Exact distance of points ``p`` to segments ``[a, b]``, row by row."""
    d = b - a
    t = np.clip(_dot(p - a, d) / np.maximum(_dot(d, d), 1e-300), 0.0, 1.0)
    e = p - (a + t[:, None] * d)
    return np.sqrt(_dot(e, e))


def kept(
    shape: BooleanShape, clip: FaceClip, x: np.ndarray, normal: Callable[[np.ndarray], np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """The margins of points ``x`` (boolean frame) on the leaf's face, whose outward normals
    there are ``normal(rows)`` (leaf frame), and whether they are on the boolean's surface: the
    margin says so where it is not zero; where it is (the point lies on another constituent's
    surface) a hair along the boolean's outward normal must be outside the boolean and a hair
    against it inside."""
    margin = clip.margin(x)
    out = margin > ON_SURFACE
    on = np.flatnonzero(np.abs(margin) <= ON_SURFACE)
    if len(on):
        n = clip.transform.apply_vectors(normal(on)) * (-1.0 if clip.flipped else 1.0)
        p = x[on]
        hit = beyond(shape, p - PROBE * n, inside=True)
        rows = np.flatnonzero(hit)  # the hair along the normal: only where the other holds
        if len(rows):
            hit[rows] = beyond(shape, p[rows] + PROBE * n[rows], inside=False)
        out[on] = hit
    return margin, out


def beyond(shape: Shape, p: np.ndarray, inside: bool) -> np.ndarray:
    """``shape.inside(p) == INSIDE`` (``inside``) or ``== OUTSIDE``, row by row, with a
    boolean's second constituent measured only at the rows its first leaves open: a boolean's
    signed distance is the min or max of its constituents' (exact), so the answer is the same
    (the probe test of :func:`kept`, where the rim build spends most of its time)."""
    while isinstance(shape, PlacedShape):
        p, shape = shape.transform.inverse_apply(p), shape.shape
    if not isinstance(shape, BooleanShape):
        half = 0.5 * TOLERANCE_G4
        s = shape.signed_distance(p)
        return np.asarray(s < -half if inside else s > half)
    op = shape.operation
    # the boolean's test as its first constituent's test, then the second's (subtracted: the
    # opposite test) joined by "or" (any) or "and" (all)
    flip = op == "subtraction"
    any_ = inside if op == "union" else not inside
    out = beyond(shape.first, p, inside)
    rows = np.flatnonzero(~out if any_ else out)
    if len(rows):
        second = shape.transform.inverse_apply(p[rows])
        out[rows] = beyond(shape.second, second, inside != flip)
    return out


class _TriangleMap:
    """A plane triangle ``(a, b, c)`` over barycentric ``(u, v)``, outward normal ``n``."""

    def __init__(self, tri: np.ndarray, n: np.ndarray) -> None:
        self.a, self.b, self.c = (np.asarray(v, float) for v in tri)
        self.n = np.asarray(n, float)
        self.roots = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
        self.edges = np.ones((1, 3), dtype=bool)

    def point(self, uv: np.ndarray) -> np.ndarray:
        return self.a + uv[..., :1] * (self.b - self.a) + uv[..., 1:] * (self.c - self.a)

    def normal(self, uv: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self.n, (*uv.shape[:-1], 3))

    def normal_at(self, x: np.ndarray) -> np.ndarray:
        """The outward normal at points ``x`` (n, 3) of the triangle."""
        return np.broadcast_to(self.n, x.shape)

    def size(self, uv: np.ndarray) -> np.ndarray:
        x = self.point(uv)
        e = np.linalg.norm(x - np.roll(x, 1, axis=1), axis=2)
        return e.max(axis=1)

    def nearest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a, b, c = self.a, self.b, self.c
        n = np.cross(b - a, c - a)
        n = n / np.linalg.norm(n)
        q = p - _dot(p - a, n)[:, None] * n
        inside = np.ones(len(p), dtype=bool)
        for u, v in ((a, b), (b, c), (c, a)):
            inside &= _dot(np.cross(v - u, q - u), n) >= 0
        best, near = np.full(len(p), np.inf), q.copy()
        for u, v in ((a, b), (b, c), (c, a)):
            d = v - u
            t = np.clip(_dot(p - u, d) / _dot(d, d), 0.0, 1.0)
            e = u + t[:, None] * d
            dist = np.linalg.norm(p - e, axis=1)
            better = ~inside & (dist < best)
            best[better], near[better] = dist[better], e[better]
        best[inside] = np.abs(_dot(p[inside] - a, n))
        return best, near


class _SweptMap:
    """A segment (r1, z1) -> (r2, z2) swept about z over [phi0, phi0 + dphi], over ``(t, s)``
    in [0, 1]^2 (``phi = phi0 + s dphi``)."""

    #: the first pieces: about this many along the longer of the two directions (nearly square,
    #: so that halving keeps them so), at least 16 around a full circle
    ROOTS = 32

    def __init__(self, patch: Revolved) -> None:
        self.p = patch
        self.full = patch.dphi >= 2 * np.pi - 1e-12
        self.length = float(np.hypot(patch.r2 - patch.r1, patch.z2 - patch.z1))
        self.rmax = max(patch.r1, patch.r2)
        cell = max(self.length, self.rmax * patch.dphi) / self.ROOTS
        rows = max(1, int(np.ceil(self.length / cell)))
        columns = max(16 if self.full else 1, int(np.ceil(self.rmax * patch.dphi / cell)))
        t = np.linspace(0, 1, rows + 1)
        s = np.linspace(0, 1, columns + 1)
        roots, edges = [], []
        for i in range(rows):
            for j in range(columns):
                c00, c10 = (t[i], s[j]), (t[i + 1], s[j])
                c01, c11 = (t[i], s[j + 1]), (t[i + 1], s[j + 1])
                low, high = i == 0, i == rows - 1
                first = j == 0 and not self.full
                last = j == columns - 1 and not self.full
                # (c00, c10, c11): edges c00-c10 (s = s_j), c10-c11 (t = t_i+1), c11-c00 inside
                roots.append([c00, c10, c11])
                edges.append([first, high, False])
                # (c00, c11, c01): c00-c11 inside, c11-c01 (s = s_j+1), c01-c00 (t = t_i)
                roots.append([c00, c11, c01])
                edges.append([False, last, low])
        self.roots = np.array(roots)
        self.edges = np.array(edges)

    def point(self, ts: np.ndarray) -> np.ndarray:
        p = self.p
        t, s = ts[..., 0], ts[..., 1]
        rho = p.r1 + t * (p.r2 - p.r1)
        phi = p.phi0 + s * p.dphi
        return np.stack([rho * np.cos(phi), rho * np.sin(phi), p.z1 + t * (p.z2 - p.z1)], -1)

    def normal(self, ts: np.ndarray) -> np.ndarray:
        return self._normal(self.p.phi0 + ts[..., 1] * self.p.dphi)

    def normal_at(self, x: np.ndarray) -> np.ndarray:
        """The outward normal at points ``x`` (n, 3) of the swept segment."""
        return self._normal(np.arctan2(x[:, 1], x[:, 0]))

    def _normal(self, phi: np.ndarray) -> np.ndarray:
        nr = self.p.nr
        return np.stack([nr * np.cos(phi), nr * np.sin(phi), np.full(phi.shape, self.p.nz)], -1)

    def size(self, ts: np.ndarray) -> np.ndarray:
        dt = np.ptp(ts[..., 0], axis=1)
        ds = np.ptp(ts[..., 1], axis=1)
        return self.length * dt + self.rmax * self.p.dphi * ds

    def nearest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = self.p
        rho, phi = np.hypot(p[:, 0], p[:, 1]), np.arctan2(p[:, 1], p[:, 0])
        dr, dz = s.r2 - s.r1, s.z2 - s.z1
        t = np.clip(
            ((rho - s.r1) * dr + (p[:, 2] - s.z1) * dz) / max(dr * dr + dz * dz, 1e-300), 0, 1
        )
        if not self.full:
            off = np.mod(phi - s.phi0, 2 * np.pi)
            out = off > s.dphi
            if out.any():  # nearest on an end meridian: the nearer end, then the segment
                ends = []
                for angle in (s.phi0, s.phi0 + s.dphi):
                    c, sn = np.cos(angle), np.sin(angle)
                    a = np.array([s.r1 * c, s.r1 * sn, s.z1])
                    b = np.array([s.r2 * c, s.r2 * sn, s.z2])
                    d = b - a
                    u = np.clip((p[out] - a) @ d / max(float(d @ d), 1e-300), 0, 1)
                    ends.append((u, angle, np.linalg.norm(p[out] - (a + u[:, None] * d), axis=1)))
                first = ends[0][2] <= ends[1][2]
                t[out] = np.where(first, ends[0][0], ends[1][0])
                phi = phi.copy()
                phi[out] = np.where(first, ends[0][1], ends[1][1])
        r, z = s.r1 + t * dr, s.z1 + t * dz
        q = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
        return np.linalg.norm(p - q, axis=1), q


def _maps(clip: FaceClip) -> list[_TriangleMap | _SweptMap]:
    leaf = clip.leaf
    index = leaf.faces.index(clip.face)
    out: list[_TriangleMap | _SweptMap] = []
    for patch in leaf.patches:
        if patch.face != index:
            continue
        if isinstance(patch, PlaneTriangles):
            out.extend(
                _TriangleMap(t, n) for t, n in zip(patch.triangles, patch.normals, strict=True)
            )
        elif isinstance(patch, Revolved):
            out.append(_SweptMap(patch))
        else:
            raise ConfigError(
                f"activeness: distances to a {type(patch).__name__} face of a {leaf.kind} are "
                "not supported (plane faces and surfaces of revolution are)"
            )
    return out


class _Rim:
    """The rim of one patch's kept part (boolean frame): chords ``a``-``b``."""

    def __init__(self, shape: BooleanShape, clip: FaceClip, m: _TriangleMap | _SweptMap) -> None:
        self.shape, self.clip, self.map = shape, clip, m
        chords: list[np.ndarray] = []  # (k, 2, 2) parameter endpoints, each on the rim
        kinds: list[np.ndarray] = []  # True: a cut curve; False: the patch's own edge
        tri, edges = m.roots, m.edges
        for _ in range(40):
            if not len(tri):
                break
            margin, kept = self._state(tri.reshape(-1, 2))
            margin, kept = margin.reshape(-1, 3), kept.reshape(-1, 3)
            size = m.size(tri)
            # a piece whose vertices all lie on another constituent's surface (a flush face, a
            # part's foot) proves nothing by its margins: it is taken whole or cut away whole
            # by their probe test once no larger than FLUSH (a hole in a flush region, or a
            # flush region that is not convex, is seen by the vertices of those pieces)
            flush = (np.abs(margin) <= ON_SURFACE).all(axis=1) & (size <= FLUSH)
            whole = kept.all(axis=1) & ((margin.max(axis=1) >= size) | flush)
            gone = ~kept.any(axis=1) & ((-margin.min(axis=1) >= size) | flush)
            for c in self._own_edges(tri[whole], edges[whole], kept[whole]):
                chords.append(c)
                kinds.append(np.zeros(len(c), dtype=bool))
            rest = ~(whole | gone)
            same = kept.all(axis=1) | ~kept.any(axis=1)
            fine = rest & ((size <= FINEST) | (same & (size <= SAME_SIDE)))
            for c, kind in self._march(tri[fine], edges[fine], kept[fine]):
                chords.append(c)
                kinds.append(kind)
            tri, edges = _halve(tri[rest & ~fine], edges[rest & ~fine])
        ends = np.concatenate(chords) if chords else np.empty((0, 2, 2))
        curve = np.concatenate(kinds) if kinds else np.empty(0, dtype=bool)
        self.unrefined = 0
        #: the swept patch's own end circles, measured exactly: (t, s0, s1) merged
        self.arcs: list[tuple[float, float, float]] = []
        if isinstance(m, _SweptMap) and len(ends):
            arc = (ends[:, 0, 0] == ends[:, 1, 0]) & ~curve
            self.arcs = _merge(ends[arc])
            ends, curve = ends[~arc], curve[~arc]
        ends, curve = self._refine(ends, curve)
        a, b = m.point(ends[:, 0]), m.point(ends[:, 1])
        self.a, self.b = _split(clip.transform.apply(a), clip.transform.apply(b))

    def _state(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The margins at parameters ``uv`` and whether those points are kept."""
        x = _apply(self.clip.transform, self.map.point(uv))
        return kept(self.shape, self.clip, x, lambda rows: self.map.normal(uv[rows]))

    def _kept(self, uv: np.ndarray) -> np.ndarray:
        return self._state(uv)[1]

    def _crossing(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Points where [u, v] (parameters, u kept, v not) crosses the rim, by bisection."""
        for _ in range(BISECT):
            mid = 0.5 * (u + v)
            k = self._kept(mid)
            u = np.where(k[:, None], mid, u)
            v = np.where(k[:, None], v, mid)
        return u

    def _own_edges(self, tri, edges, kept):
        """Chords of the patch's edges (flags ``edges``) of pieces: whole where both ends are
        kept, from the kept end to the crossing where one is."""
        for e in range(3):
            sel = edges[:, e]
            if not sel.any():
                continue
            u, v = tri[sel, e], tri[sel, (e + 1) % 3]
            ku, kv = kept[sel, e], kept[sel, (e + 1) % 3]
            both = ku & kv
            if both.any():
                yield np.stack([u[both], v[both]], axis=1)
            one = ku ^ kv
            if one.any():
                a = np.where(ku[one, None], u[one], v[one])
                b = np.where(ku[one, None], v[one], u[one])
                yield np.stack([a, self._crossing(a, b)], axis=1)

    def _march(self, tri, edges, kept):
        for c in self._own_edges(tri, edges, kept):
            yield c, np.zeros(len(c), dtype=bool)
        mixed = kept.any(axis=1) & ~kept.all(axis=1)
        if not mixed.any():
            return
        tri, kept = tri[mixed], kept[mixed]
        # each mixed piece: two of its edges change side; the chord joins their crossings
        changes = [kept[:, k] != kept[:, (k + 1) % 3] for k in range(3)]
        cross = []
        for e in range(3):
            u, v = tri[:, e], tri[:, (e + 1) % 3]
            ku = kept[:, e]
            a, b = np.where(ku[:, None], u, v), np.where(ku[:, None], v, u)
            c = a.copy()  # only the edges that change side cross the rim (rows are independent)
            c[changes[e]] = self._crossing(a[changes[e]], b[changes[e]])
            cross.append(c)
        first = np.where(changes[0][:, None], cross[0], cross[1])
        second = np.where(changes[2][:, None], cross[2], cross[1])
        c = np.stack([first, second], axis=1)
        yield c, np.ones(len(c), dtype=bool)

    def _refine(self, ends: np.ndarray, curve: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Split chords until each is within TOLERANCE of the rim at its midpoint."""
        done: list[np.ndarray] = []
        for _ in range(40):
            if not len(ends):
                break
            mid = 0.5 * (ends[:, 0] + ends[:, 1])
            on = mid.copy()
            if curve.any():
                on[curve], ok = self._onto_rim(ends[curve], mid[curve])
                self.unrefined += int((~ok).sum())
            chord = 0.5 * (self.map.point(ends[:, 0]) + self.map.point(ends[:, 1]))
            gap = np.linalg.norm(self.map.point(on) - chord, axis=1)
            split = gap > TOLERANCE
            if curve.any():
                split[curve] &= ok
            done.append(ends[~split])
            e, c, o = ends[split], curve[split], on[split]
            ends = np.concatenate([np.stack([e[:, 0], o], 1), np.stack([o, e[:, 1]], 1)])
            curve = np.concatenate([c, c])
        done.append(ends)
        out = np.concatenate(done)
        return out, np.zeros(len(out), dtype=bool)

    def _onto_rim(self, ends: np.ndarray, mid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Chord midpoints moved across the chord (parameter space) onto the rim."""
        d = ends[:, 1] - ends[:, 0]
        across = np.column_stack([-d[:, 1], d[:, 0]])
        lo, hi = mid - across, mid + across
        k_lo, k_mid, k_hi = self._kept(lo), self._kept(mid), self._kept(hi)
        ok = (k_lo != k_mid) | (k_hi != k_mid)
        other = np.where((k_lo != k_mid)[:, None], lo, hi)
        a = np.where(k_mid[:, None], mid, other)
        b = np.where(k_mid[:, None], other, mid)
        out = mid.copy()
        if ok.any():
            out[ok] = self._crossing(a[ok], b[ok])
        return out, ok


def _merge(ends: np.ndarray) -> list[tuple[float, float, float]]:
    """Pieces of circles (parameter chords at one t) joined where they meet: (t, s0, s1)."""
    t = ends[:, 0, 0]
    s0, s1 = np.minimum(ends[:, 0, 1], ends[:, 1, 1]), np.maximum(ends[:, 0, 1], ends[:, 1, 1])
    out: list[tuple[float, float, float]] = []
    for k in np.lexsort((s0, t)):
        if out and out[-1][0] == t[k] and s0[k] <= out[-1][2] + 1e-12:
            out[-1] = (out[-1][0], out[-1][1], max(out[-1][2], float(s1[k])))
        else:
            out.append((float(t[k]), float(s0[k]), float(s1[k])))
    return out


def arc_distance(p: np.ndarray, rho: float, z: float, phi: float, dphi: float) -> np.ndarray:
    """Exact distance of points (the arc's frame) to the circle of radius ``rho`` at height ``z``
    over azimuths [phi, phi + dphi]."""
    r = np.hypot(p[:, 0], p[:, 1])
    on = np.mod(np.arctan2(p[:, 1], p[:, 0]) - phi, 2 * np.pi) <= dphi
    ends = [
        np.linalg.norm(p - np.array([rho * np.cos(a), rho * np.sin(a), z]), axis=1)
        for a in (phi, phi + dphi)
    ]
    return np.where(on, np.hypot(r - rho, p[:, 2] - z), np.minimum(*ends))


def _rows(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, rows: np.ndarray) -> np.ndarray:
    return f(x[rows])


def _apply(t: Transform, x: np.ndarray) -> np.ndarray:
    """``t.apply(x)``, without the product for a shift (most constituents)."""
    if np.array_equal(t.rotation, np.eye(3)):
        return x + t.translation
    return t.apply(x)


def _halve(tri: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle in four by its edge midpoints, with the patch-edge flags of the pieces."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
    e0, e1, e2 = edges[:, 0], edges[:, 1], edges[:, 2]
    no = np.zeros_like(e0)
    pieces = [
        (np.stack([a, ab, ca], 1), np.stack([e0, no, e2], 1)),
        (np.stack([ab, b, bc], 1), np.stack([e0, e1, no], 1)),
        (np.stack([ca, bc, c], 1), np.stack([no, e1, e2], 1)),
        (np.stack([ab, bc, ca], 1), np.stack([no, no, no], 1)),
    ]
    return np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces])


def _split(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Chords longer than PIECE cut into equal parts no longer than it (straight: exact)."""
    n = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / PIECE), 1).astype(np.int64)
    rows = np.repeat(np.arange(len(a)), n)
    k = np.arange(len(rows)) - np.repeat(np.cumsum(n) - n, n)
    f0, f1 = (k / n[rows])[:, None], ((k + 1) / n[rows])[:, None]
    d = b[rows] - a[rows]
    return a[rows] + f0 * d, a[rows] + f1 * d


class KeptFaceDistance:
    """Exact distance (to :data:`TOLERANCE`) of points in a boolean's frame to the listed faces
    of ``shape`` as they are on the boolean (smooth faces; see the module's text); ``keep``
    (clip, patch map) selects some of the faces' patches (one plane of a face of several)."""

    def __init__(
        self,
        shape: BooleanShape,
        faces: tuple[str, ...],
        keep: Callable[[FaceClip, _TriangleMap | _SweptMap], bool] | None = None,
    ) -> None:
        self.shape = shape
        self.patches: list[tuple[FaceClip, _TriangleMap | _SweptMap]] = []
        for name in faces:
            clip = shape.face_clip(name)
            self.patches.extend((clip, m) for m in _maps(clip) if keep is None or keep(clip, m))
        self._rim: tuple[np.ndarray, np.ndarray] | None = None

    def rim(self) -> tuple[np.ndarray, np.ndarray]:
        """The rim chords (ends ``a``, ``b``: (k, 3) each), built on first use."""
        if self._rim is None:
            rims = [_Rim(self.shape, clip, m) for clip, m in self.patches]
            self.unrefined = sum(r.unrefined for r in rims)
            self._arcs = []
            for r in rims:
                if not r.arcs:
                    continue
                assert isinstance(r.map, _SweptMap)
                w = r.map.p
                for t, s0, s1 in r.arcs:
                    rho, z = w.r1 + t * (w.r2 - w.r1), w.z1 + t * (w.z2 - w.z1)
                    phi, dphi = w.phi0 + s0 * w.dphi, (s1 - s0) * w.dphi
                    self._arcs.append((r.clip.transform, rho, z, phi, dphi))
            a = np.concatenate([r.a for r in rims]) if rims else np.empty((0, 3))
            b = np.concatenate([r.b for r in rims]) if rims else np.empty((0, 3))
            self._rim = (a, b)
            # chords by length (short ones where the rim bends): a k-d tree of midpoints each
            half = 0.5 * np.linalg.norm(b - a, axis=1)
            self._groups = []
            for lo, hi in ((0.0, 0.01 * PIECE), (0.01 * PIECE, 0.1 * PIECE), (0.1 * PIECE, np.inf)):
                sel = np.flatnonzero((half > lo) & (half <= hi) | ((lo == 0.0) & (half == 0.0)))
                if len(sel):
                    from scipy.spatial import cKDTree  # lazily: see rough_distance

                    mid = 0.5 * (a[sel] + b[sel])
                    self._groups.append((cKDTree(mid), sel, float(half[sel].max())))
        return self._rim

    def __call__(self, local: np.ndarray) -> np.ndarray:
        p = np.asarray(local, float).reshape(-1, 3)
        best = np.full(len(p), np.inf)
        lost = np.zeros(len(p), dtype=bool)  # a patch's nearest point is cut away
        for clip, m in self.patches:
            d, q = m.nearest(clip.transform.inverse_apply(p))
            normal = partial(_rows, m.normal_at, q)
            on = kept(self.shape, clip, _apply(clip.transform, q), normal)[1]
            best = np.where(on, np.minimum(best, d), best)
            lost |= ~on
        rows = np.flatnonzero(lost)
        if len(rows):
            best[rows] = np.minimum(best[rows], self.to_rim(p[rows]))
        return best

    def to_rim(self, p: np.ndarray) -> np.ndarray:
        """Exact distance of points to the rim chords: per group of chords, the nearest
        midpoint's chord bounds the distance; every chord whose midpoint lies within that bound
        plus the group's largest half-chord is measured."""
        a, b = self.rim()
        best = np.full(len(p), np.inf)
        for transform, rho, z, phi, dphi in self._arcs:
            best = np.minimum(best, arc_distance(transform.inverse_apply(p), rho, z, phi, dphi))
        for tree, sel, _ in self._groups:
            _, i = tree.query(p)
            best = np.minimum(best, segment_distance(p, a[sel[i]], b[sel[i]]))
        for tree, sel, half in self._groups:
            found = tree.query_ball_point(p, best + half)
            counts = np.fromiter((len(f) for f in found), np.int64, len(p))
            if not counts.sum():
                continue
            idx = sel[np.concatenate([np.asarray(f, np.int64) for f in found])]
            rows = np.repeat(np.arange(len(p)), counts)
            d = segment_distance(p[rows], a[idx], b[idx])
            np.minimum.at(best, rows, d)
        return best
