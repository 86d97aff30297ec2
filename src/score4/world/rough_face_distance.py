"""Exact distance of points to a rough face of a boolean solid laid as flat layers (one per
plane of the face) or curved ones (a cylinder or cone piece each), for activeness on listed
faces (:mod:`score4.world.boolean_distance`; numpy and scipy, no Geant4).

A flat layer tiles its face's plane with a square grid that may reach past the face (a round
floor, a face cut by another constituent): its patches stand only on cells wholly on the
boolean's face (:func:`score4.world.boolean_layers.kept_cells`), the other cells stay flat, and
of those only the part on the face is the boolean's surface. So the rough face is the patch
tops (:class:`score4.world.rough_distance.RoughSurfaceDistance` without its flat cells) and
the *flat rest*: the face at the layer's level (``F``: the cut face with ``into``, as it is on
the boolean, :class:`score4.world.kept_face_distance.KeptFaceDistance`) less the patch cells'
squares. The distance to that rest, for a point at height ``z`` over the plane whose foot is
``q``:

- ``q`` in no patch cell: the distance to ``F`` itself. Where ``q`` is on ``F`` it is ``|z|``
  and ``q`` is in the rest; where not, ``F``'s nearest point is on ``F``'s rim, which lies in
  the rest (a patch cell is wholly on ``F``, so ``F``'s rim meets it only on its border, shared
  with a flat cell or at a corner).
- ``q`` in a patch cell: the rest's nearest point lies on the rest's border, which is part of
  ``F``'s rim and the sides of the patch cells that face a cell without a patch (the sides lie
  on ``F``, closed): the smaller of the distance to ``F``'s rim (exact to
  :data:`~score4.world.kept_face_distance.TOLERANCE`) and to those sides (exact).

The face's distance is the smaller of the patch tops' and the rest's. It is exact to the rim's
TOLERANCE where the patch tops' distance is (every point less than the tops' ``exact_depth``
below them, 300 facet radii; deeper, the tops' lower bound).

A curved layer (:class:`_CurvedLayerFace`) is the same on its cylinder or cone piece: the bent
patch tops (:class:`~score4.world.rough_distance.CurvedRoughSurfaceDistance` without the cells
that hold none) and the face at the layer's level, where the boolean keeps it, less the patch
footprints (cell ``(j, i)``: azimuths ``phi`` +- ``px / (2 r_j)``, generator ``v_j`` +-
``py / 2``), so the azimuth gap at a ring's ends (a ring holds whole cells) and any gap
between rings are rest. On such a piece the only point of the whole surface that can be a
nearest one inside a region is the point's foot (the other azimuth's is a farthest one), so
the argument above holds with the foot for ``q``; the footprints' sides are generator
segments and arcs about the axis (exact). Like
:class:`~score4.world.rough_distance.RoughSurfaceDistance`, the walls of the patches' base slab
(``base_thickness``) at the edge of a patch region are not part of the surface.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..shapes import BooleanShape
from ..shapes.faces import RevolvedFace
from .kept_face_distance import KeptFaceDistance, segment_distance
from .rough_distance import CurvedRoughSurfaceDistance, RoughSurfaceDistance

if TYPE_CHECKING:
    from .scene import CurvedRoughLayer, RoughLayer

#: relative tolerance (of the face's size) for a patch of the leaf's face to lie in a layer's
#: plane
IN_PLANE = 1e-9


class _FlatLayerFace:
    """One flat layer's part of the face: its patch tops and its flat rest."""

    def __init__(self, layer: RoughLayer) -> None:
        on = layer.on_boolean
        assert on is not None
        assert isinstance(on.shape, BooleanShape)
        self.layer, self.on = layer, on
        self.tops = RoughSurfaceDistance(layer, flat=False)
        # the face at the level, in this layer's plane (a face of several planes has a layer
        # per plane; each plane's part of the face is its own)
        to_layer = layer.frame

        def in_plane(clip, m) -> bool:
            x = clip.transform.apply(m.point(m.roots.reshape(-1, 2)))
            z = to_layer.to_local(on.transform.apply(x))[:, 2]
            scale = max(float(np.abs(x).max()), 1.0)
            return bool(np.all(np.abs(z) <= IN_PLANE * scale))

        self.level = KeptFaceDistance(on.shape, (on.face,), keep=in_plane)
        if not self.level.patches:
            raise AssertionError(f"{layer.name}: no part of {on.face} lies at the layer's level")
        self.cells = np.asarray(layer.cell_variants)
        self.cx, self.cy = layer.patch_map.cell_centre_axes()
        self.px, self.py = layer.patch_size
        a, b = self._sides()
        self.a, self.b = a, b
        from scipy.spatial import cKDTree  # lazily: see rough_distance._Variant

        self.tree = cKDTree(0.5 * (a + b)) if len(a) else None
        self.half = 0.5 * max(self.px, self.py)

    def _sides(self) -> tuple[np.ndarray, np.ndarray]:
        """The sides of the patch cells that face a cell without a patch (or the grid's
        border): segments at z = 0 of the layer's frame."""
        patch = self.cells >= 0
        padded = np.pad(patch, 1, constant_values=False)
        hx, hy = self.px / 2, self.py / 2
        a, b = [], []
        for dj, di, (u0, v0), (u1, v1) in (
            (0, -1, (-hx, -hy), (-hx, hy)),
            (0, 1, (hx, -hy), (hx, hy)),
            (-1, 0, (-hx, -hy), (hx, -hy)),
            (1, 0, (-hx, hy), (hx, hy)),
        ):
            neighbour = padded[1 + dj : padded.shape[0] - 1 + dj, 1 + di : padded.shape[1] - 1 + di]
            j, i = np.nonzero(patch & ~neighbour)
            c = np.column_stack([self.cx[i], self.cy[j], np.zeros(len(i))])
            a.append(c + np.array([u0, v0, 0.0]))
            b.append(c + np.array([u1, v1, 0.0]))
        return np.concatenate(a), np.concatenate(b)

    def _to_sides(self, q: np.ndarray) -> np.ndarray:
        best = np.full(len(q), np.inf)
        if self.tree is None or not len(q):
            return best
        _, k = self.tree.query(q)
        best = segment_distance(q, self.a[k], self.b[k])
        found = self.tree.query_ball_point(q, best + self.half)
        counts = np.fromiter((len(f) for f in found), np.int64, len(q))
        idx = np.concatenate([np.asarray(f, np.int64) for f in found])
        rows = np.repeat(np.arange(len(q)), counts)
        np.minimum.at(best, rows, segment_distance(q[rows], self.a[idx], self.b[idx]))
        return best

    def __call__(self, world: np.ndarray) -> np.ndarray:
        q = self.layer.frame.to_local(world)
        local = self.on.transform.inverse_apply(world)
        i, j = self.layer.patch_map.cell_of(q[:, :2])
        in_patch = i >= 0
        in_patch[in_patch] = self.cells[j[in_patch], i[in_patch]] >= 0
        return _tops_or_rest(self, world, q, local, in_patch)


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.mod(a + np.pi, 2 * np.pi) - np.pi


def _arc_rows(q: np.ndarray, rho, z, phi, half) -> np.ndarray:
    """Exact distance of points ``q`` to arcs about the z axis, row by row: radius ``rho`` at
    height ``z`` over azimuths ``phi`` +- ``half`` (< pi)."""
    d = _wrap(np.arctan2(q[:, 1], q[:, 0]) - phi)
    on = np.abs(d) <= half
    end = phi + np.sign(d) * half
    e = np.column_stack([rho * np.cos(end), rho * np.sin(end), z])
    return np.where(
        on, np.hypot(np.hypot(q[:, 0], q[:, 1]) - rho, q[:, 2] - z), np.linalg.norm(q - e, axis=1)
    )


#: gaps (mm, rad) below which neighbouring patch footprints touch
TOUCH = 1e-9


class _CurvedLayerFace:
    """One curved layer's part of the face (a cylinder or cone piece, the target's frame with
    its axis along z): its bent patch tops and its flat rest, the face at the layer's level
    less the patch footprints (cell ``(j, i)``: azimuths ``phi`` +- ``px / (2 r_j)``, generator
    ``v_j`` +- ``py / 2``; the azimuth gap at a ring's ends and the gaps between rings are rest).
    """

    def __init__(self, layer: CurvedRoughLayer) -> None:
        on = layer.on_boolean
        assert on is not None
        assert isinstance(on.shape, BooleanShape)
        self.layer, self.on = layer, on
        self.lay = lay = layer.ring_layout
        face = lay.face
        assert isinstance(face, RevolvedFace), "sphere faces are refused by world.resolve"
        self.face = face
        self.tops = CurvedRoughSurfaceDistance(layer, flat=False)

        def on_face(clip, m) -> bool:
            x = clip.transform.apply(m.point(m.roots.reshape(-1, 2)))
            q = layer.target.to_local(on.transform.apply(x))
            h = face.locate(q)[2]
            return bool(np.all(np.abs(h) <= IN_PLANE * max(float(np.abs(q).max()), 1.0)))

        self.level = KeptFaceDistance(on.shape, (on.face,), keep=on_face)
        if not self.level.patches:
            raise AssertionError(f"{layer.name}: no part of {on.face} lies at the layer's level")
        self.cells = np.asarray(layer.cell_variants)
        self.px, self.py = layer.patch_size
        self._sides()

    def _sides(self) -> None:
        """The footprints' sides that face no patch: generator segments (``a``, ``b``) and
        arcs (``arc``: radius, z, azimuth, half width)."""
        lay, face, px, py = self.lay, self.face, self.px, self.py
        rings = len(lay.v)
        patch: list[np.ndarray] = []
        for j in range(rings):
            n = int(lay.count[j])
            patch.append(np.flatnonzero(self.cells[j, :n] >= 0))
        a, b, arcs = [], [], []
        for j in range(rings):
            n, step, r = int(lay.count[j]), float(lay.step[j]), float(lay.radius[j])
            phi = lay.cell_phi(j)
            w = px / (2 * r)
            touch = abs(step * r - px) <= TOUCH
            closed = touch and abs(n * step - 2 * np.pi) <= TOUCH
            held = set(patch[j].tolist())
            lo, hi = lay.v[j] - py / 2, lay.v[j] + py / 2
            for i in patch[j]:
                for di, side in ((-1, phi[i] - w), (1, phi[i] + w)):
                    k = i + di
                    if closed:
                        k %= n
                    if not (touch and k in held):
                        a.append(face.point(side, lo))
                        b.append(face.point(side, hi))
            # arcs: each footprint's lower and upper side less the footprints of the ring
            # whose band it touches
            for edge, jn in ((lo, j - 1), (hi, j + 1)):
                rz = face.point(0.0, edge)
                c, wn = np.empty(0), 0.0
                if 0 <= jn < rings and abs(abs(lay.v[jn] - lay.v[j]) - py) <= TOUCH:
                    wn = px / (2 * float(lay.radius[jn]))
                    c = lay.cell_phi(jn)[patch[jn]]
                for i in patch[j]:
                    near = c[np.abs(_wrap(c - phi[i])) < w + wn + TOUCH]
                    others = np.column_stack([near - wn, near + wn])
                    for s0, s1 in _less(phi[i] - w, phi[i] + w, others):
                        arcs.append((rz[0], rz[2], 0.5 * (s0 + s1), 0.5 * (s1 - s0)))
        from scipy.spatial import cKDTree  # lazily: see rough_distance._Variant

        self.a = np.array(a).reshape(-1, 3)
        self.b = np.array(b).reshape(-1, 3)
        self.arc = np.array(arcs).reshape(-1, 4)
        self.seg_tree = cKDTree(0.5 * (self.a + self.b)) if len(self.a) else None
        mid = self.arc
        self.arc_mid = np.column_stack(
            [mid[:, 0] * np.cos(mid[:, 2]), mid[:, 0] * np.sin(mid[:, 2]), mid[:, 1]]
        )
        self.arc_tree = cKDTree(self.arc_mid) if len(self.arc) else None
        self.half = 0.5 * max(px, py)

    def _near(self, q, tree, measure) -> np.ndarray:
        best = np.full(len(q), np.inf)
        if tree is None or not len(q):
            return best
        _, k = tree.query(q)
        best = measure(q, k)
        found = tree.query_ball_point(q, best + self.half)
        counts = np.fromiter((len(f) for f in found), np.int64, len(q))
        idx = np.concatenate([np.asarray(f, np.int64) for f in found])
        rows = np.repeat(np.arange(len(q)), counts)
        np.minimum.at(best, rows, measure(q[rows], idx))
        return best

    def _to_sides(self, q: np.ndarray) -> np.ndarray:
        def seg(p, k):
            return segment_distance(p, self.a[k], self.b[k])

        def arc(p, k):
            c = self.arc[k]
            return _arc_rows(p, c[:, 0], c[:, 1], c[:, 2], c[:, 3])

        return np.minimum(self._near(q, self.seg_tree, seg), self._near(q, self.arc_tree, arc))

    def __call__(self, world: np.ndarray) -> np.ndarray:
        q = self.tops.local(world)
        local = self.on.transform.inverse_apply(world)
        j, i, xy = self.lay.locate(q)
        in_patch = j >= 0
        in_patch[in_patch] = self.cells[j[in_patch], i[in_patch]] >= 0
        in_patch &= np.abs(xy[:, 0]) <= self.px / 2
        return _tops_or_rest(self, world, q, local, in_patch)


def _less(lo: float, hi: float, others: np.ndarray) -> list[tuple[float, float]]:
    """The interval [lo, hi] (azimuths) less the intervals ``others`` (rows lo, hi; each
    moved by whole turns next to it)."""
    out = [(lo, hi)]
    mid = 0.5 * (lo + hi)
    for o0, o1 in others:
        shift = 2 * np.pi * np.round((0.5 * (o0 + o1) - mid) / (2 * np.pi))
        o0, o1 = o0 - shift, o1 - shift
        if o1 <= lo or o0 >= hi:
            continue
        nxt = []
        for s0, s1 in out:
            if s0 < o0 - TOUCH:
                nxt.append((s0, min(s1, o0)))
            if s1 > o1 + TOUCH:
                nxt.append((max(s0, o1), s1))
        out = nxt
    return out


class RoughFaceDistance:
    """Distance (mm) of world points to a rough face of a boolean laid as ``layers`` (flat ones,
    one per plane, and curved ones, one per cylinder or cone piece): the nearest of each
    layer's patch tops and flat rest (see the module's text)."""

    def __init__(self, layers: list[RoughLayer | CurvedRoughLayer]) -> None:
        assert layers
        self.parts: list[_FlatLayerFace | _CurvedLayerFace] = [
            _CurvedLayerFace(layer) if layer.curved else _FlatLayerFace(layer)  # type: ignore[arg-type]
            for layer in layers
        ]

    def __call__(self, world: np.ndarray) -> np.ndarray:
        world = np.asarray(world, float).reshape(-1, 3)
        best = np.full(len(world), np.inf)
        for part in self.parts:
            best = np.minimum(best, part(world))
        return best


def _tops_or_rest(
    face: _FlatLayerFace | _CurvedLayerFace,
    world: np.ndarray,
    q: np.ndarray,
    local: np.ndarray,
    in_patch: np.ndarray,
) -> np.ndarray:
    """The nearer of ``face``'s patch tops and its flat rest: the face at the layer's level where
    a point's foot is in no patch cell, else the nearer of that face's rim and the patch-cell
    sides that face no patch (``q`` in the layer's frame, ``local`` in the solid's)."""
    rest = np.empty(len(q))
    off = ~in_patch
    if off.any():
        rest[off] = face.level(local[off])
    if in_patch.any():
        rows = np.flatnonzero(in_patch)
        rest[rows] = np.minimum(face.level.to_rim(local[rows]), face._to_sides(q[rows]))
    return np.minimum(face.tops(world), rest)
