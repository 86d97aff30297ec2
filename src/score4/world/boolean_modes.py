"""What a rough layer on a boolean solid's face takes besides its geometry (numpy, no Geant4):
``tiling``, ``native_layout`` and ``into``, checked by :mod:`score4.world.boolean_layers`.

* ``tiling: portal`` cannot work on a boolean's face, for two reasons: a portal's subworlds must
  lie where no particle goes, which score4 knows only in the world it generates, whose targets
  are boxes of the configuration (a boolean solid comes from a GDML world); and a portal jumps
  into a variant's subworld from every cell, while a boolean's face keeps patches only on the
  cells proven on its surface (the others stay flat).
* ``native_layout: replicas`` repeats one cell box over the whole rectangle of cells: it works
  where every cell of a flat face holds its patch (a face the other solids do not cut, such as
  the side of a box less a tube along its axis), and is refused, with the count of cells off the
  surface, where they do not.
* ``into: true`` on a face of a constituent that is not subtracted (a flat face of a G4Box;
  a wall or end face of a G4Tubs, G4Cons or polycone; the sphere face of a G4Sphere or G4Orb):
  the constituent is made thinner behind the face
  (:func:`cut_boolean`; in Geant4 the boolean is rebuilt with it,
  :mod:`score4.geometry.boolean_cut`), and the layer lies in the slab (on a curved face the
  shell, laid out as on a plain solid's wall cut for ``into``), on the cut face
  (:func:`cut_face`); on the wall of a subtracted G4Tubs or G4Cons (a bore) the subtracted solid
  grows by the layer's cut and the layer lies in the shell around the old bore; on a face of a
  subtracted G4Box or an end face of a subtracted G4Tubs (a blind hole's floor) that solid
  grows by the layer's thickness along the face's own normal (into the kept volume: against the
  boolean's outward normal there), and the layer lies in the slab, on the grown solid's face.
  The same holds for the flat faces of a subtracted G4Cons, G4Polycone or G4GenericPolycone
  (their (r, z) contour's edge moved, the neighbours' lines kept), G4Trd (a G4Trd again) and
  G4Polyhedra (the apothem contour's edge moved: a G4GenericPolyhedra); the layer's cells are
  those the grown solid fills over the whole slab (on the old face and on the grown one: a
  hole narrowing to its floor loses its outer ring of cells). On the sphere face of a
  subtracted G4Orb or G4Sphere (a spherical dimple or cavity, laid out as the inner face of a
  shell beside it) the subtracted solid grows by the layer's cut, as a bore does. Refused
  elsewhere: the phi faces of a subtracted solid, the faces of a subtracted G4Trap, tessellated
  or extruded solid, the other curved faces of subtracted solids, the phi faces of a segment
  (moved off the axis they would make the constituent a boolean of its own), and two faces that
  share an edge of one constituent swept around z that is not subtracted
  (:func:`check_shared_edges`; plain solids get a joint cut there).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError
from ..shapes import BooleanShape, G4Cons, G4Orb, G4Sphere, G4Tubs, Shape, Transform
from ..shapes.base import PlaneTriangles
from ..shapes.faces import PlaneFace
from ..shapes.placed import PlacedShape
from ..shapes.revolved import RevolvedShape
from .boolean_distance import leaf_path
from .scene import (
    BooleanFace,
    CurvedRoughLayer,
    PolygonRoughLayer,
    RingRoughLayer,
    RoughLayer,
    TargetVolume,
)

if TYPE_CHECKING:  # a worker imports this module and never the configuration's models
    from ..inputs.config import RoughFace


def check_modes(
    rough: RoughFace, where: str, what: str, leaf: Shape, face: str, flipped: bool
) -> None:
    """One-line errors for ``into: true`` and ``tiling: portal`` on a boolean's face ``what``
    (face ``face`` of its constituent ``leaf``; ``flipped``: of a subtracted solid)."""
    if rough.into:
        flat = flat_face(leaf, face)
        bore = isinstance(leaf, G4Tubs | G4Cons | G4Sphere | G4Orb) and face in ("outer", "inner")
        grows = flat and leaf.moved({face: -1e-6}) is not None
        if flipped and not (bore or grows):
            raise ConfigError(
                f"{where}: into: true on {what}, a face of the subtracted {leaf.kind}, would "
                "widen the cut, which score4 does for the walls of a subtracted G4Tubs or "
                "G4Cons (a bore), the sphere faces of a subtracted G4Orb or G4Sphere and the "
                "flat faces of a subtracted G4Box, G4Tubs, G4Cons, G4Polycone, "
                "G4GenericPolycone, G4Trd or G4Polyhedra (not phi faces) only; put the layer "
                "outside the volume (into: false)"
            )
        if not flipped and face in ("phi_start", "phi_end"):
            raise ConfigError(
                f"{where}: into: true on {what} (face {face} of a {leaf.kind} with a phi "
                "segment): the cut would move that plane off the axis, which no "
                f"{leaf.kind} can be (the constituent would become a boolean of its own), and "
                "the wall's cells along the phi edge would have to be laid out again; put the "
                "layer outside the volume (into: false)"
            )
        if not flipped and leaf.trimmed({face: 1e-6}) is None:
            raise ConfigError(
                f"{where}: into: true on {what} (face {face} of a {leaf.kind}) needs a "
                "constituent score4 can make thinner behind that face (the faces of a G4Box; "
                "the walls and end faces of a G4Tubs, G4Cons or polycone; the sphere faces of "
                "a G4Sphere or G4Orb); put the layer outside the volume (into: false)"
            )
    if rough.tiling == "portal":
        raise ConfigError(
            f"{where}: tiling portal on {what}: a portal's subworlds must lie where no particle "
            "goes, which score4 knows only in the world it generates, whose targets are boxes "
            "(a boolean solid comes from a GDML world), and it jumps into a patch from every "
            "cell, while a boolean's face keeps patches only where it lies on the solid's "
            "surface; take tiling: native"
        )


def flat_face(leaf: Shape, face: str) -> bool:
    """True for a face of flat facets: one plane, or several (the sides of a G4Polyhedra)."""
    try:
        return isinstance(leaf.face(face), PlaneFace)
    except ConfigError:  # not one plane
        pass
    k = leaf.faces.index(face)
    patches = [p for p in leaf.patches if p.face == k]
    return bool(patches) and all(isinstance(p, PlaneTriangles) for p in patches)


def check_shared_edges(layers: list[RoughLayer], target: TargetVolume, where: str) -> None:
    """One-line error for ``into`` on two faces of one constituent of a boolean target swept
    around z (not a subtracted one) that share an edge (``layers``: the target's layers;
    ``where``: the error's start): each layer is laid out on its own cut, and their slabs
    would meet at the edge (the joint cut that plain solids get,
    :func:`score4.world.scene.check_into_edges`, is not made for a boolean's constituents). The
    layers on a subtracted solid's faces grow apart from their concave edge (the square
    between their slabs belongs to neither), so they are not refused."""
    shape, name = target.shape, target.name
    if not isinstance(shape, BooleanShape):
        return
    faces = [r.config.face_name for r in layers if r.config.into]
    by_leaf: dict[str, list[str]] = {}
    for face in faces:
        path, leaf_face = leaf_path(shape, face)
        by_leaf.setdefault(path, []).append(leaf_face)
    for path, own in by_leaf.items():
        clip = shape.face_clip(path + own[0])
        leaf = clip.leaf
        if len(own) < 2 or not isinstance(leaf, RevolvedShape) or clip.flipped:
            continue  # a subtracted solid's edges are concave: its layers grow apart
        poly, names = leaf.contour()
        for k, a in enumerate(names):
            b = names[(k + 1) % len(names)]
            if a in own and b in own:
                r, z = poly[(k + 1) % len(poly)]
                raise ConfigError(
                    f"{where}: into: true on faces {path}{a} and {path}{b} of {name!r}, faces of "
                    f"one {leaf.kind} of the boolean that share an edge (the circle r = {r:.4g} "
                    f"mm at z = {z:.4g} mm in its frame): score4 cuts such faces together on "
                    "plain solids only; put one of them outside the volume (into: false)"
                )


def check_replicas(layer: RoughLayer, where: str, what: str) -> None:
    """``native_layout: replicas`` on a boolean's face: every cell of a flat rectangle holds its
    patch, or a one-line error (call once the kept cells are known)."""
    if layer.config.native_layout != "replicas":
        return
    if isinstance(layer, CurvedRoughLayer | PolygonRoughLayer | RingRoughLayer):
        return  # refused on the constituent's face already (a rectangle only)
    mask = layer.mask
    if mask is None:
        return
    off = int(mask.size - mask.sum())
    if off:
        raise ConfigError(
            f"{where}: native_layout replicas fills every cell; {off} of the {mask.size} cells of "
            f"{what} lie off the solid's surface (or are not proven on it) and hold no patch: "
            "take auto, nested or placements"
        )


def leaf_cuts(shape: BooleanShape, cuts: dict[str, float]) -> dict[str, tuple[Shape, np.ndarray]]:
    """Per leaf path (:func:`score4.world.boolean_distance.leaf_path`), the leaf made thinner
    behind the named boolean faces (``cuts``: face -> depth, mm; :meth:`Shape.trimmed`) and the
    shift of its origin in the leaf's frame."""
    by_path: dict[str, dict[str, float]] = {}
    for name, depth in cuts.items():
        path, face = leaf_path(shape, name)
        by_path.setdefault(path, {})[face] = depth
    out = {}
    for path, faces in by_path.items():
        leaf = shape.face_clip(path + next(iter(faces))).leaf
        trimmed = leaf.moved(faces)
        if trimmed is None:  # refused by check_modes before
            raise ConfigError(f"into: a {leaf.kind} cannot be cut behind {', '.join(faces)}")
        out[path] = trimmed
    return out


def cut_boolean(shape: BooleanShape, cuts: dict[str, float]) -> BooleanShape:
    """``shape`` with the leaves behind the named faces made thinner by the depths ``cuts``
    (the solid an ``into`` layer leaves: the face moved inward, the other faces where they
    were)."""
    trims = leaf_cuts(shape, cuts)

    def cut(s: Shape, path: str) -> Shape:
        if isinstance(s, PlacedShape):
            return replace(s, shape=cut(s.shape, path))
        if isinstance(s, BooleanShape):
            return replace(
                s, first=cut(s.first, path + "first."), second=cut(s.second, path + "second.")
            )
        if path not in trims:
            return s
        trimmed, shift = trims[path]
        return PlacedShape(trimmed, Transform(np.eye(3), np.asarray(shift, float)))

    out = cut(shape, "")
    assert isinstance(out, BooleanShape)
    return out


def into_depth(layer: RoughLayer, flipped: bool) -> float:
    """How far an ``into`` layer moves its boolean face inward (mm): the layer's thickness on a
    flat face; on a bore (``flipped``: a subtracted tube's wall, laid out as the inner wall of a
    tube beside it) the cut of that tube's inner radius; on a curved face of a constituent that
    is not subtracted, the cut of that constituent behind the face (``into_cut``)."""
    if isinstance(layer, CurvedRoughLayer) and not (
        flipped and isinstance(layer.target.shape, G4Tubs)
    ):
        return float(layer.into_cut)
    if isinstance(layer, CurvedRoughLayer):
        turned = layer.target.shape
        assert layer.cut_shape is not None  # into on a wall: the tube cut for it
        cut = layer.cut_shape[0]
        assert isinstance(turned, G4Tubs)
        assert isinstance(cut, G4Tubs)
        return float(cut.rmin - turned.rmin)
    return float(layer.thickness)


def cut_face(on: BooleanFace, depth: float) -> BooleanFace:
    """Where an ``into`` layer's face lies: the face ``on`` of the boolean cut ``depth`` behind
    it (:func:`cut_boolean`; a subtracted solid grows by ``depth``)."""
    shape = on.shape
    assert isinstance(shape, BooleanShape)
    cut = cut_boolean(shape, {on.face: -depth if on.clip.flipped else depth})
    return BooleanFace(cut, on.face, cut.face_clip(on.face), on.transform)


def boolean_cuts(layers: list[RoughLayer]) -> dict[str, float]:
    """The cuts of a boolean's ``into`` layers (boolean face -> depth, mm, < 0: a subtracted
    solid grows), as :func:`cut_boolean` and :func:`score4.geometry.boolean_cut.cut_boolean_solid`
    take them."""
    out = {}
    for layer in layers:
        on = layer.on_boolean
        assert on is not None
        depth = into_depth(layer, on.clip.flipped)
        out[layer.config.face_name] = -depth if on.clip.flipped else depth
    return out
