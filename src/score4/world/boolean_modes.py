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
  grows by the layer's cut and the layer lies in the shell around the old bore, and so on a
  cylinder or cone wall of a subtracted polycone (:func:`polycone_wall`: its (r, z) contour's
  edge moved out along its normal, the neighbours' lines kept, so a ledge next to it gets
  shorter; refused in one line where a neighbour would vanish; where a cone neighbour makes
  the grown wall shorter, the layer is laid out on the part kept,
  :func:`score4.world.boolean_layers._grown_wall_extent`); on a face of a
  subtracted G4Box or an end face of a subtracted G4Tubs (a blind hole's floor) that solid
  grows by the layer's thickness along the face's own normal (into the kept volume: against the
  boolean's outward normal there), and the layer lies in the slab, on the grown solid's face.
  The same holds for the flat faces of a subtracted G4Cons, G4Polycone or G4GenericPolycone
  (their (r, z) contour's edge moved, the neighbours' lines kept), G4Trd (a G4Trd again) and
  G4Polyhedra (the apothem contour's edge moved: a G4GenericPolyhedra); the layer's cells are
  those the grown solid fills over the whole slab (on the old face and on the grown one: a
  hole narrowing to its floor loses its outer ring of cells). On the sphere face of a
  subtracted G4Orb or G4Sphere (a spherical dimple or cavity, laid out as the inner face of a
  shell beside it) the subtracted solid grows by the layer's cut, as a bore does. A flat face
  of a subtracted G4Trap moves its plane (a G4Trap again, rebuilt from its eight corners); a
  face (one plane, or every plane of a face of several) of a subtracted G4ExtrudedSolid or
  G4TessellatedSolid moves its vertices to
  where their planes meet again (:meth:`score4.shapes.MeshShape.moved`, a G4TessellatedSolid in
  Geant4), refused in one line where that leaves no valid solid (a corner on more planes than
  meet the moved one in a point, a facet turned over, a facet crossing another). Refused
  elsewhere: the phi faces of any constituent, subtracted or not (moved off the axis, parallel
  to itself, the plane would make the constituent a boolean of its own: no Geant4 solid with
  phi faces has them off its axis), and the theta cones of a subtracted G4Sphere (a cone moved
  parallel to itself no longer has its apex at the sphere's centre, as a G4Sphere's theta
  cones do).
  A part of a union that stands on a cut flat face grows down by the cut, so the slab under it
  stays in the volume (:func:`standing_cuts`: a G4Box, or a G4Tubs, G4Cons or polycone, along
  the face's normal, its foot within the face; a swept part grows as the prism of its foot,
  :func:`leaf_cuts`; other parts that meet the slab are refused). Two ``into`` faces of one
  constituent not subtracted that share an edge, or one and the foot it grows down by, are cut
  together as on a plain solid (:func:`joint_leaves`,
  :func:`score4.world.boolean_layers.into_joint`); refused on a constituent with a phi segment
  and on a part grown down whose walls do not rise from its foot along its axis.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError
from ..shapes import (
    BooleanShape,
    G4Box,
    G4Cons,
    G4GenericPolycone,
    G4Orb,
    G4Polycone,
    G4Sphere,
    G4Tubs,
    Shape,
    Transform,
)
from ..shapes.base import PlaneTriangles
from ..shapes.boolean import FaceClip
from ..shapes.faces import PlaneFace
from ..shapes.placed import PlacedShape
from ..shapes.revolved import RevolvedShape
from .boolean_distance import leaf_path
from .facets import face_triangles, plane_face, plane_groups
from .scene import (
    SWEPT_INTO,
    BooleanFace,
    CurvedRoughLayer,
    PolygonRoughLayer,
    RingRoughLayer,
    RoughLayer,
    TargetVolume,
    edge_circle,
    shared_edge,
    shared_edge_error,
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
        bore = bore or polycone_wall(leaf, face) is not None
        phi = face in ("phi_start", "phi_end")
        grows = False
        if flipped and flat and not phi:
            try:
                grows = leaf.moved({face: -1e-6}) is not None
            except ConfigError as err:  # a mesh whose face cannot move at all (Shape.moved)
                raise ConfigError(f"{where}: into: true on {what}: {err}") from None
        if flipped and phi:
            raise ConfigError(
                f"{where}: into: true on {what} (face {face} of the subtracted {leaf.kind} with "
                "a phi segment): growing that solid by the layer's thickness would move the "
                f"plane off the axis, parallel to itself, and every {leaf.kind}'s phi faces pass "
                f"through its axis: the grown solid would be the {leaf.kind} joined to a slab "
                "along the face, a boolean of its own, which score4 does not build inside the "
                "cut (the cells along the phi edge would also have to be laid out again); put "
                "the layer outside the volume (into: false)"
            )
        if flipped and isinstance(leaf, G4Sphere) and face in ("theta_start", "theta_end"):
            raise ConfigError(
                f"{where}: into: true on {what} (the theta cone {face} of the subtracted "
                "G4Sphere): growing the sphere by the layer's thickness along that cone would "
                "add a slab whose face is the cone moved parallel to itself, off the sphere's "
                "centre, and every G4Sphere's theta cones have their apex at its centre: the "
                "grown solid would be a boolean of its own, which score4 does not build inside "
                "the cut; put the layer outside the volume (into: false)"
            )
        if flipped and not (bore or grows):
            raise ConfigError(
                f"{where}: into: true on {what}, a face of the subtracted {leaf.kind}, would "
                "widen the cut, which score4 does for the walls of a subtracted G4Tubs, "
                "G4Cons (a bore) or polycone (its cylinder and cone walls), the sphere "
                "faces of a subtracted G4Orb or G4Sphere and the "
                "flat faces of a subtracted G4Box, G4Tubs, G4Cons, G4Polycone, "
                "G4GenericPolycone, G4Trd, G4Trap, G4Polyhedra, extruded or tessellated solid "
                "(a face with no facet of zero area) only; put the layer outside the volume "
                "(into: false)"
            )
        if not flipped and phi:
            raise ConfigError(
                f"{where}: into: true on {what} (face {face} of a {leaf.kind} with a phi "
                "segment): the cut would move that plane off the axis, parallel to itself, and "
                f"every {leaf.kind}'s phi faces pass through its axis: the cut constituent "
                f"would be the {leaf.kind} less a slab along the face, a boolean of its own, "
                "which score4 does not build inside the cut (the wall's cells along the phi "
                "edge would also have to be laid out again); put the layer outside the volume "
                "(into: false)"
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


def polycone_wall(leaf: Shape, face: str) -> tuple[Shape, str, float] | None:
    """The face ``face`` of a polycone that is a cylinder or cone wall (a segment of the
    contour between two z planes) turned as :func:`turned_wall` turns a G4Tubs's or G4Cons's
    wall: the ``inner`` wall of a G4Tubs or G4Cons whose inner radii are the segment's (a
    segment facing away from the axis: the bore the subtracted polycone leaves) or the
    ``outer`` wall of a full one with the segment's radii (a segment facing the axis), over the
    segment's z range, and the z of its centre in the polycone's frame; None for other faces
    (flat rings, phi faces, group names)."""
    if not isinstance(leaf, G4Polycone | G4GenericPolycone):
        return None
    poly, names = leaf.contour()
    if face not in names:
        return None
    k = names.index(face)
    (ra, za), (rb, zb) = poly[k], poly[(k + 1) % len(poly)]
    if za == zb:
        return None  # a flat ring
    (r1, z1), (r2, z2) = [
        (float(r), float(z)) for r, z in sorted([(ra, za), (rb, zb)], key=lambda p: p[1])
    ]
    dz, phi = (z2 - z1) / 2, (leaf.sphi, leaf.dphi)
    away = zb > za  # counter-clockwise: an edge going up faces away from the axis
    turned: Shape
    if r1 == r2:
        turned = G4Tubs(r1, 2 * r1, dz, *phi) if away else G4Tubs(0.0, r1, dz, *phi)
    elif away:
        w = max(r1, r2)
        turned = G4Cons(r1, r1 + w, r2, r2 + w, dz, *phi)
    else:
        turned = G4Cons(0.0, r1, 0.0, r2, dz, *phi)
    return turned, "inner" if away else "outer", (z1 + z2) / 2


def flat_face(leaf: Shape, face: str) -> bool:
    """True for a face of flat facets: one plane, or several (the sides of a G4Polyhedra)."""
    try:
        return isinstance(leaf.face(face), PlaneFace)
    except ConfigError:  # not one plane
        pass
    k = leaf.faces.index(face)
    patches = [p for p in leaf.patches if p.face == k]
    return bool(patches) and all(isinstance(p, PlaneTriangles) for p in patches)


def joint_leaves(
    layers: list[RoughLayer], target: TargetVolume, where: str
) -> tuple[dict[str, dict[str, float]], list[str]]:
    """The constituents of a boolean target (``layers``: its layers; ``where``: the errors'
    start) cut behind faces that share an edge, each to be cut for them together as a plain
    solid is (their joint cut, :func:`score4.world.scene.joint_layout`): two ``into`` faces of
    its own (a post's wall and top), or one and the foot it grows down by under another part's
    ``into`` face (:func:`standing_cuts`: a post's wall and the disk's top it stands on).
    Returns the leaf path of each such constituent with the feet it grows by (its face ->
    depth < 0), and the boolean faces whose layers lie on such a constituent or under it, to be
    laid out again on the joint cut. A subtracted solid's faces grow apart from their concave
    edges (the square between their slabs belongs to neither) and need none.

    One-line errors where score4 makes no joint cut: on a constituent with a phi segment; on a
    part grown down whose foot meets a face cut for a layer of its own, unless the part is a
    full G4Tubs, G4Cons or polycone whose walls rise from the foot along its axis (a cone
    leaning over its foot grows as the prism of its foot, and its wall's cut would run on
    along its slope), and on a box post whose side meets its foot grown down (the two cuts
    would leave a vacuum notch along the foot)."""
    shape, name = target.shape, target.name
    if not isinstance(shape, BooleanShape):
        return {}, []
    into = [r for r in layers if r.config.into]
    own: dict[str, list[str]] = {}
    for r in into:
        path, leaf_face = leaf_path(shape, r.config.face_name)
        if leaf_face not in own.setdefault(path, []):
            own[path].append(leaf_face)
    feet: dict[str, dict[str, float]] = {}
    under: dict[str, list[str]] = {}  # a grown part's path -> the faces it stands on
    for r in into:
        face = r.config.face_name
        for grown, depth in standing_cuts(shape, face, r.thickness, where).items():
            path, foot = leaf_path(shape, grown)
            feet.setdefault(path, {})[foot] = depth
            under.setdefault(path, []).append(face)
    joint: dict[str, dict[str, float]] = {}
    involved: list[str] = []
    for path, faces in own.items():
        clip = shape.face_clip(path + faces[0])
        leaf, grown_by = clip.leaf, feet.get(path, {})
        if clip.flipped:
            continue  # a subtracted solid's edges are concave: its layers grow apart
        if isinstance(leaf, G4Box) and grown_by:
            side = next((f for f in faces if f[1] not in "".join(grown_by)), None)
            if side is not None:  # a side of a box post meets its foot, grown down
                foot = next(iter(grown_by))
                raise ConfigError(
                    f"{where}: into: true on faces {under[path][0]} and {path}{side} of "
                    f"{name!r}: the box {path.rstrip('.')} of the union stands on face "
                    f"{under[path][0]} and grows down into its cut (its face {foot}), and its "
                    f"side {side} meets that foot; score4 cuts a side and the foot of a part "
                    "together only on a G4Tubs, G4Cons or polycone with a full circle (the two "
                    "cuts would leave a vacuum notch along the foot); put one of them outside "
                    "the volume (into: false)"
                )
        if not isinstance(leaf, RevolvedShape):
            continue  # a box's faces sharing an edge: refused by the clearance check
        edge = shared_edge(leaf, [*faces, *grown_by])
        if edge is None:
            continue
        a, b, edge_r, edge_z = edge
        swept = leaf.kind in SWEPT_INTO and leaf.full_phi
        if (a in grown_by or b in grown_by) and not (swept and straight_feet(leaf, grown_by)):
            mine = a if b in grown_by else b
            raise ConfigError(
                f"{where}: into: true on faces {under[path][0]} and {path}{mine} of {name!r}: "
                f"the part {path.rstrip('.')} of the union stands on face {under[path][0]} and "
                f"grows down into its cut, and score4 cuts a face of such a part that meets its "
                "foot only on a G4Tubs, G4Cons or polycone with a full circle whose walls rise "
                "from the foot along its axis (the two cuts would leave a gap at their edge); "
                "put one of them outside the volume (into: false)"
            )
        if not swept:
            raise shared_edge_error(
                where,
                (path + a, path + b),
                name,
                f"faces of one {leaf.kind} of the boolean that share an edge "
                f"({edge_circle(edge_r, edge_z)} in its frame)",
                "on a G4Tubs, G4Cons or polycone with a full circle only",
            )
        joint[path] = grown_by
        for face in [path + f for f in faces] + under.get(path, []):
            if face not in involved:
                involved.append(face)
    return joint, involved


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
        clip = shape.face_clip(path + next(iter(faces)))
        leaf = clip.leaf
        feet = {} if clip.flipped else {f: -d for f, d in faces.items() if d < 0}
        if feet and isinstance(leaf, RevolvedShape) and not straight_feet(leaf, feet):
            cuts_ = {f: d for f, d in faces.items() if d >= 0}
            trimmed = leaf.footed(cuts_, feet)  # a part grown down as the prism of its foot
        else:
            trimmed = leaf.moved(faces)
        if trimmed is None:  # refused by check_modes before
            raise ConfigError(f"into: a {leaf.kind} cannot be cut behind {', '.join(faces)}")
        out[path] = trimmed
    return out


def straight_feet(leaf: RevolvedShape, feet: Collection[str]) -> bool:
    """Whether the walls that meet the flat end faces ``feet`` of ``leaf`` run along its axis
    (or lie on it): the foot moved outward with its neighbours' lines kept (:meth:`Shape.moved`)
    is then the prism of the foot (:meth:`RevolvedShape.footed`)."""
    poly, names = leaf.contour()
    n = len(poly)
    for face in feet:
        k = names.index(face)
        for j in ((k - 1) % n, (k + 1) % n):
            if poly[j, 0] != poly[(j + 1) % n, 0]:
                return False
    return True


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


def _union_siblings(shape: BooleanShape, path: str) -> list[tuple[Shape, Transform, str, bool]]:
    """The other parts of every union on the way from ``shape`` to the leaf at ``path``: each
    ``(part, its frame in the boolean's, its path, whether only unions lie between that union
    and the leaf)`` (else a subtraction or intersection below it may have taken some of the
    leaf under the part)."""
    node: Shape = shape
    at = Transform()
    found: list[tuple[Shape, Transform, str, int]] = []
    ops: list[str] = []
    done = ""
    for token in path.split(".")[:-1]:
        while isinstance(node, PlacedShape):
            at, node = at @ node.transform, node.shape
        assert isinstance(node, BooleanShape)
        first, second = (node.first, at), (node.second, at @ node.transform)
        (nxt, nxt_at), (other, other_at) = (first, second) if token == "first" else (second, first)
        if node.operation == "union":
            other_name = "second." if token == "first" else "first."
            found.append((other, other_at, done + other_name, len(ops)))
        ops.append(node.operation)
        done += token + "."
        node, at = nxt, nxt_at
    return [(p, a, n, all(op == "union" for op in ops[k + 1 :])) for p, a, n, k in found]


def _inside_face(leaf: Shape, face: str, placed: Transform, points: np.ndarray, r: float) -> bool:
    """Whether the disks of radius ``r`` around ``points`` (boolean frame, on the plane of the
    flat face ``face`` of ``leaf`` placed by ``placed``) lie within the face: exact for a box's
    face (a rectangle) and the end face of a full G4Tubs without a bore (a disk)."""
    q = placed.inverse_apply(points)
    if isinstance(leaf, G4Box):
        axis = "xyz".index(face[1])
        half = np.delete(np.array([leaf.dx, leaf.dy, leaf.dz]), axis)
        return bool((np.abs(np.delete(q, axis, axis=1)) + r <= half + 1e-12).all())
    if isinstance(leaf, G4Tubs) and leaf.rmin == 0 and leaf.dphi >= 2 * np.pi:
        return bool((np.hypot(q[:, 0], q[:, 1]) + r <= leaf.rmax + 1e-12).all())
    return False


def _grow_down(
    leaf: Shape,
    placed: Transform,
    clip: FaceClip,
    n: np.ndarray,
    origin: np.ndarray,
    depth: float,
    name: str,
) -> dict[str, float] | None:
    """For a part ``leaf`` of a union (placed by ``placed`` in the boolean's frame, at ``name``)
    that meets the slab ``depth`` behind the face of ``clip`` (normal ``n`` through ``origin``):
    the cut that grows it down to fill the slab under it (``{}``: it goes through the slab
    already), or None where no such cut is exact (:func:`standing_cuts`)."""
    if isinstance(leaf, G4Box):
        return _grow_box(leaf, placed, clip, n, origin, depth, name)
    if not isinstance(leaf, RevolvedShape) or leaf.kind not in SWEPT_INTO:
        return None
    c = float(placed.rotation[:, 2] @ n)
    if abs(abs(c) - 1.0) > 1e-12:
        return None  # its axis is not along the normal
    h = float((placed.translation - origin) @ n)
    poly, names = leaf.contour()
    height = h + c * poly[:, 1]  # of the contour's corners above the face's plane
    if height.min() > 1e-9 or height.max() < -depth - 1e-9:
        return {}  # off the slab
    m, feet = len(poly), []
    for i in range(m):
        if not (poly[(i + 1) % m, 0] - poly[i, 0]) * c > 0:
            continue  # the edge's face does not look down the normal
        lo, hi = sorted((float(height[i]), float(height[(i + 1) % m])))
        if max(abs(lo), abs(hi)) <= 1e-9 and height.min() >= -1e-9:
            feet.append(i)  # its foot, on the face's plane
            continue
        if hi <= -depth + 1e-9 or lo >= -1e-9:
            continue  # under the slab (the part goes through it) or above the face
        return None  # a face looking down in the slab: the cut would leave a gap under it
    if not feet:
        return {}
    if len(feet) > 1:
        return None
    k = feet[0]
    rim = float(max(poly[k, 0], poly[(k + 1) % m, 0]))
    centre = placed.translation - h * n
    if not _inside_face(clip.leaf, clip.face, clip.transform, centre[None], rim):
        return None
    return {name + names[k]: -depth}


def _grow_box(
    leaf: G4Box,
    placed: Transform,
    clip: FaceClip,
    n: np.ndarray,
    origin: np.ndarray,
    depth: float,
    name: str,
) -> dict[str, float] | None:
    """:func:`_grow_down` for a G4Box: one of its axes along the normal."""
    half = np.array([leaf.dx, leaf.dy, leaf.dz])
    for k in range(3):
        c = float(placed.rotation[:, k] @ n)
        if abs(abs(c) - 1.0) > 1e-12:
            continue
        h = float((placed.translation - origin) @ n)
        foot, top = h - half[k], h + half[k]
        if (foot <= -depth + 1e-9 and top >= -1e-9) or foot > 1e-9 or top < -depth - 1e-9:
            return {}  # through the slab (it fills its column already), or off it
        if abs(foot) > 1e-9:
            return None  # it ends in the slab
        centre = placed.translation - h * n
        e = [placed.rotation[:, j] * half[j] for j in range(3) if j != k]
        feet = np.array([centre + a * e[0] + b * e[1] for a in (-1, 1) for b in (-1, 1)])
        if not _inside_face(clip.leaf, clip.face, clip.transform, feet, 0.0):
            return None
        return {name + ("-" if c > 0 else "+") + "xyz"[k]: -depth}
    return None


def _beside_slab(
    frame: Transform, plane: PlaneFace, lo: np.ndarray, hi: np.ndarray, depth: float
) -> bool:
    """Whether a part whose bounding box is ``lo`` .. ``hi`` (the boolean's frame) shares no
    inner point with the slab ``depth`` behind the flat face ``plane`` of a G4Box (placed by
    ``frame``: the slab is the face's rectangle times ``depth``, exactly) and does not stand on
    the face: its box, in the face's frame, lies beyond one of the rectangle's edges (it may
    touch the slab's side: a disk under a box post's side, whose foot stands on it) or behind
    the slab. A part touching the face itself within the rectangle stands on it."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])  # fmt: skip
    q = frame.inverse_apply(corners)
    qlo, qhi = q.min(axis=0), q.max(axis=0)
    (u0, u1), (v0, v1) = plane.extent
    eps = 1e-9
    return bool(
        qhi[0] <= u0 + eps
        or qlo[0] >= u1 - eps
        or qhi[1] <= v0 + eps
        or qlo[1] >= v1 - eps
        or qhi[2] <= -depth + eps
    )


def standing_cuts(shape: BooleanShape, face: str, depth: float, what: str) -> dict[str, float]:
    """The other parts of a union that stand on the flat face ``face`` (of a constituent not
    subtracted) cut ``depth`` behind it for ``into``, grown down by ``depth`` (boolean face ->
    depth < 0, as :func:`cut_boolean` takes them) so the slab under them stays in the volume:
    a G4Box, or a G4Tubs, G4Cons, G4Polycone or G4GenericPolycone, along the face's normal
    whose foot lies on the face's plane, within the face (a box's face or a full tube's end
    face without a bore), with no face looking down into the slab but its foot, joined to the
    face's constituent by unions only (no subtraction between them); a swept part grows as the
    prism of its foot (:func:`leaf_cuts`). A part already through the slab needs nothing, nor
    does one that touches the slab of a G4Box's face only beside it or behind it
    (:func:`_beside_slab`: the disk under a box post's side); any other part that meets the
    slab (a sphere, a boolean, a part leaning over the face, a foot
    reaching beyond the face, a part ending in the slab) is refused in one line (``what``: its
    start), and so is any part that meets the slab behind a face of several planes (a
    G4Polyhedra's sides)."""
    clip = shape.face_clip(face)
    if clip.flipped:  # a subtracted solid's face: no part of the union stands on it
        return {}
    try:
        planes = [clip.leaf.face(clip.face)]
    except ConfigError:  # a face of several planes (a G4Polyhedra's sides): each plane's slab
        if not flat_face(clip.leaf, clip.face):
            return {}
        groups = plane_groups(face_triangles(clip.leaf, clip.face))
        planes = [plane_face(clip.face, tris) for tris in groups]
    if not isinstance(planes[0], PlaneFace):
        return {}
    path = face[: len(face) - len(clip.face)]
    out = {}
    for part, at, name, clean in _union_siblings(shape, path):
        lo, hi = PlacedShape(part, at).bounding_box()
        leaf, placed = part, at
        while isinstance(leaf, PlacedShape):
            placed, leaf = placed @ leaf.transform, leaf.shape
        for plane in planes:
            assert isinstance(plane, PlaneFace)
            frame = clip.transform @ plane.frame
            n, origin = frame.rotation[:, 2], frame.translation
            (u0, u1), (v0, v1) = plane.extent
            rim = frame.apply(
                np.array([[u, v, h] for u in (u0, u1) for v in (v0, v1) for h in (-depth, 0)])
            )
            if (hi < rim.min(axis=0) - 1e-9).any() or (lo > rim.max(axis=0) + 1e-9).any():
                continue  # away from the slab
            if isinstance(clip.leaf, G4Box) and _beside_slab(frame, plane, lo, hi, depth):
                continue  # it touches the slab at most on its sides or back: it stands elsewhere
            grow = _grow_down(leaf, placed, clip, n, origin, depth, name)
            if grow and (not clean or len(planes) > 1):  # it could grow into what a
                grow = None  # subtraction took from the face's constituent under it
            if grow is None:
                several = (
                    f" (a face of {len(planes)} planes, and score4 grows a part down into the "
                    "cut of a face of one plane only)"
                    if len(planes) > 1
                    else ""
                )
                raise ConfigError(
                    f"{what}: another part of the union (the {leaf.kind} {name.rstrip('.')}) "
                    f"stands on this face{several}; the cut {depth * 1e3:.4g} um behind it would "
                    "leave a gap under that part, and score4 grows such a part down into the cut "
                    "only when it is a G4Box, or a G4Tubs, G4Cons or polycone, along the face's "
                    "normal whose foot lies on the face's plane, within the face (a box's face "
                    "or the end face of a full tube), with no other face looking down into the "
                    "cut; put the layer outside the volume (into: false)"
                )
            out.update(grow)
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
        assert isinstance(cut, G4Tubs)  # its inner wall moved out or its outer wall in
        return float(cut.rmin - turned.rmin + turned.rmax - cut.rmax)
    return float(layer.thickness)


def cut_face(on: BooleanFace, depth: float, what: str = "into") -> BooleanFace:
    """Where an ``into`` layer's face lies: the face ``on`` of the boolean cut ``depth`` behind
    it (:func:`cut_boolean`; a subtracted solid grows by ``depth``; the parts of a union that
    stand on the face grow down by it, :func:`standing_cuts`, whose errors start with
    ``what``)."""
    shape = on.shape
    assert isinstance(shape, BooleanShape)
    grow = standing_cuts(shape, on.face, depth, what)
    cut = cut_boolean(shape, {on.face: -depth if on.clip.flipped else depth, **grow})
    return BooleanFace(cut, on.face, cut.face_clip(on.face), on.transform)


def boolean_cuts(layers: list[RoughLayer], shape: BooleanShape) -> dict[str, float]:
    """The cuts of the ``into`` layers of the boolean ``shape`` (boolean face -> depth, mm,
    < 0: a subtracted solid grows, and so does a part of a union standing on a cut face,
    :func:`standing_cuts`), as :func:`cut_boolean` and
    :func:`score4.geometry.boolean_cut.cut_boolean_solid` take them."""
    out = {}
    for layer in layers:
        on = layer.on_boolean
        assert on is not None
        depth = into_depth(layer, on.clip.flipped)
        out[layer.config.face_name] = -depth if on.clip.flipped else depth
        out.update(standing_cuts(shape, layer.config.face_name, depth, "into"))
    return out
