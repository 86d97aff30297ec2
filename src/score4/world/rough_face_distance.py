"""Exact distance of points to a rough face of a boolean solid laid as flat layers (one per
plane of the face), for activeness on listed faces (:mod:`score4.world.boolean_distance`;
numpy and scipy, no Geant4).

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
below them, 300 facet radii; deeper, the tops' lower bound). Like
:class:`~score4.world.rough_distance.RoughSurfaceDistance`, the walls of the patches' base slab
(``base_thickness``) at the edge of a patch region are not part of the surface.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..shapes import BooleanShape
from .kept_face_distance import KeptFaceDistance, segment_distance
from .rough_distance import RoughSurfaceDistance

if TYPE_CHECKING:
    from .scene import RoughLayer

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
        rest = np.empty(len(q))
        off = ~in_patch
        if off.any():
            rest[off] = self.level(local[off])
        if in_patch.any():
            rows = np.flatnonzero(in_patch)
            rest[rows] = np.minimum(self.level.to_rim(local[rows]), self._to_sides(q[rows]))
        return np.minimum(self.tops(world), rest)


class FlatRoughFaceDistance:
    """Distance (mm) of world points to a rough face of a boolean laid as flat ``layers`` (one
    per plane of the face): the nearest of each layer's patch tops and flat rest (see the
    module's text)."""

    def __init__(self, layers: list[RoughLayer]) -> None:
        assert layers
        assert not any(layer.curved for layer in layers)
        self.parts = [_FlatLayerFace(layer) for layer in layers]

    def __call__(self, world: np.ndarray) -> np.ndarray:
        world = np.asarray(world, float).reshape(-1, 3)
        best = np.full(len(world), np.inf)
        for part in self.parts:
            best = np.minimum(best, part(world))
        return best
