"""A Geant4 boolean solid read from GDML, rebuilt with constituents made thinner for ``into``
layers (:func:`score4.world.boolean_modes.cut_boolean` on the shapes' side).

Only the nodes on the way from the boolean to a cut constituent are new: each is the same
operation (``G4UnionSolid``, ``G4SubtractionSolid``, ``G4IntersectionSolid``) of the same
other constituent at the same placement (``G4DisplacedSolid``: its object rotation and
translation); the cut constituent is the Geant4 solid of the thinner shape
(:func:`score4.geometry.built.g4_solid`), whose shift goes up the tree to the volume's
placement. Untouched constituents are Geant4's own objects."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from score4.shapes import BooleanShape, Shape, Transform
from score4.world.boolean_modes import leaf_cuts

from .solid_shapes import _rotation, _vector
from .tiling import _rotation as g4_rotation

BOOLEANS = ("G4UnionSolid", "G4SubtractionSolid", "G4IntersectionSolid")


def _transform3d(g4, t: Transform):
    return g4.G4Transform3D(g4_rotation(g4, t.rotation), g4.G4ThreeVector(*t.translation))


def _placement(solid: Any) -> Transform:
    return Transform(_rotation(solid.GetObjectRotation()), _vector(solid.GetObjectTranslation()))


def cut_boolean_solid(
    g4,
    solid: Any,
    shape: BooleanShape,
    cuts: dict[str, float],
    name: str,
    g4_solid: Callable[[Any, Shape, str], Any],
) -> tuple[Any, np.ndarray, list]:
    """``solid`` (the Geant4 boolean of ``shape``) with the constituents behind the faces of
    ``cuts`` (boolean face -> depth, mm) made thinner; ``(solid, shift, objects to keep)``: the
    new solid's origin lies at ``shift`` in the old one's frame (the volume's placement moves by
    it, as for a box cut for ``into``). ``g4_solid`` makes the Geant4 solid of a shape
    (:func:`score4.geometry.built.g4_solid`)."""
    trims = leaf_cuts(shape, cuts)
    keep: list = []
    zero = np.zeros(3)

    def rebuild(s: Any, path: str, tag: str) -> tuple[Any, bool, np.ndarray]:
        """(the new solid, whether it changed, its shift: the node is the new solid moved by
        it). A moved first constituent is not written to GDML by every tool (pyg4ometry drops
        ``firstposition``), so the shift goes up to the parent and, at the top, to the
        volume's placement."""
        kind = s.GetEntityType()
        if kind == "G4DisplacedSolid":
            inner, changed, shift = rebuild(s.GetConstituentMovedSolid(), path, tag + "i")
            if not changed:
                return s, False, zero
            at = _placement(s)
            moved = Transform(at.rotation, at.translation + at.rotation @ shift)
            out = g4.G4DisplacedSolid(f"{name}_{tag}", inner, _transform3d(g4, moved))
            keep.append(out)
            return out, True, zero
        if kind in BOOLEANS:
            a, b = s.GetConstituentSolid(0), s.GetConstituentSolid(1)
            at = Transform()
            if b.GetEntityType() == "G4DisplacedSolid":
                at, b = _placement(b), b.GetConstituentMovedSolid()
            na, ca, sa = rebuild(a, path + "first.", tag + "a")
            nb, cb, sb = rebuild(b, path + "second.", tag + "b")
            if not (ca or cb):
                return s, False, zero
            # op(A moved by sa, B' placed by at after its shift sb) = op(A, B' placed by
            # at . sb less sa) moved by sa
            second = Transform(at.rotation, at.translation + at.rotation @ sb - sa)
            out = getattr(g4, kind)(f"{name}_{tag}", na, nb, _transform3d(g4, second))
            keep.append(out)
            return out, True, sa
        if path not in trims:
            return s, False, zero
        trimmed, shift = trims[path]
        thin = g4_solid(g4, trimmed, f"{name}_{tag}")
        keep.append(thin)
        return thin, True, np.asarray(shift, float)

    out, changed, shift = rebuild(solid, "", "n")
    assert changed, "every cut names a constituent of the solid"
    return out, shift, keep
