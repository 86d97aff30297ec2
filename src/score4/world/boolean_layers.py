"""Rough layers on faces of boolean solids (G4UnionSolid, G4SubtractionSolid,
G4IntersectionSolid; numpy, no Geant4), and :func:`target_layers`, the one entry point that
makes the layers of a rough entry on any target.

A face of a boolean is a face of one *leaf* solid (a box, tube, polycone, ...) cut by the other
solids (:meth:`score4.shapes.BooleanShape.face_clip`). Its layer is laid out on the leaf's whole
face as on any solid (:func:`target_layers`: a flat face, a cylinder or cone
wall), and a cell keeps its patch only when the whole cell is proven on the boolean's surface:
the cutting solids' signed distances bound how far the kept part of the face reaches from a
point (:meth:`score4.shapes.boolean.FaceClip.margin`), so a cell whose centre lies deeper in the
kept part than the cell's half-diagonal is wholly kept; a cell with a point off the kept part
stays flat; other cells are split in four, down to :data:`LEVELS` times, and a cell with a piece
left unproven stays flat. The flat rest of the face
(its part on the boolean's surface outside the rough cells) is sampled by rejection
(:class:`score4.source.build.BooleanRemainderSampler`); ``rough_shares`` reports the rough share
of the boolean's face, whose area is estimated (:attr:`BooleanShape.face_area_errors`).

The wall of a subtracted G4Tubs or G4Cons (a bore) faces the other way than the solid's: its
layer is laid out as on the opposite wall of a solid beside it (:func:`turned_wall`: the bore is
the ``inner`` wall of a tube or cone whose inner radii are the subtracted solid's), cut along the
axis to where the boolean can be, so the layer lies in the bore and its shell ends where the
solid does; a cylinder or cone wall of a subtracted polycone (a stepped or tapered bore, or the
post an annular polycone leaves) is turned so over its segment's z range
(:func:`~score4.world.boolean_modes.polycone_wall`); the sphere face of a subtracted G4Orb or
G4Sphere (a spherical dimple or cavity) is the inner face of a shell around it (or the outer
face of a ball inside a subtracted shell); a theta cone of a subtracted G4Sphere is the wall of
a G4Cons over the cone's z range (:func:`theta_wall`), whose envelope ends on the rings' band
cones, as the sphere faces meet the cone at right angles (:func:`theta_rims`). A sphere face
of a G4Sphere or G4Orb leaf takes the sphere's cells (a cell's points lie within its
half-height plus the sphere radius times its half-angle of its centre).

A flat face partly covered by another part of a union (the layer's envelope would run into
the solid): only the cells whose whole column (the cell up to the layer's thickness) is proven
clear of the cutting solids keep their patch, and the envelope becomes the prism of those cells
(:func:`_clear_of_the_solid`); :func:`fit_cells` then keeps them clear of the volume's other
layers too (a wall's layer rising from the face). A cylinder or cone wall whose kept cells
leave azimuths or rings flat takes an envelope in pieces over its kept cells
(:func:`envelope_pieces`): P00664B's side wall leaves out the cut, where the cut face's layer
stands; a rod's (or a cone's) wall running through a box is two pieces, one each side of the
box.

A face of a leaf made of flat facets in several planes (the sides of a G4Polyhedra) takes one
layer per plane (:func:`_on_boolean`; a plane without a kept cell gets none); the source draws
their flat rest as one (:class:`score4.source.build.PlanesRemainderSampler`).

Refused, in one line each (:mod:`score4.world.boolean_modes` says why): ``into: true`` on the
faces of a subtracted solid other than its flat faces (a G4Box, G4Tubs, G4Cons, polycone, G4Trd,
G4Trap or G4Polyhedra; a face of an extruded or tessellated solid, where moving it leaves a
valid solid), the walls of a G4Tubs or G4Cons (bores), the cylinder and cone walls of
a polycone and the sphere faces of a G4Orb or G4Sphere (a G4Sphere's theta cones among them),
on phi faces, and on two faces that
share an edge of one constituent with a phi segment or of a part grown down under another
layer that is not swept straight up from its foot (where they can be, they are cut together:
:func:`into_joint`), ``tiling: portal``,
``native_layout: replicas`` where a cell holds no patch (and on a layer whose envelope is the
prism of its kept cells); a curved face of a subtracted solid other than a G4Tubs, G4Cons
or polycone wall, a sphere face or a G4Sphere's theta cone (one at right angles to the axis, or
reaching the centre); a curved layer
whose envelope, even in pieces, runs into the solid itself (another part of a union), a flat one
that keeps no cell clear of the other parts.
Steps and activeness measure these layers through the boolean's constituents
(:mod:`score4.world.boolean_distance`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from score4.errors import ConfigError
from score4.inputs.config import RoughFace
from score4.shapes import (
    BooleanShape,
    G4Box,
    G4Cons,
    G4GenericPolycone,
    G4Orb,
    G4Polycone,
    G4Sphere,
    G4Tubs,
    PlacedShape,
    Shape,
    Transform,
)
from score4.shapes.base import INSIDE
from score4.shapes.boolean import FaceClip
from score4.shapes.faces import AnnulusFace, RevolvedFace, SphereFace
from score4.surface.rough import Surface

from .boolean_distance import leaf_path
from .boolean_modes import (
    boolean_cuts,
    check_modes,
    check_replicas,
    cut_boolean,
    cut_face,
    flat_face,
    into_depth,
    joint_leaves,
    polycone_wall,
)
from .curved import cone_ring_span
from .facets import ccw, cells_inside, face_triangles, plane_face, plane_groups
from .scene import (
    BooleanFace,
    CurvedRoughLayer,
    EnvelopePiece,
    FaceFrame,
    PolygonRoughLayer,
    RingRoughLayer,
    RoughLayer,
    Scene,
    TargetVolume,
    joint_layout,
    make_layer,
    make_polygon_layer,
    ring_cells,
)

#: Halvings of a cell when its centre's margin does not prove it whole (a cell cut by the
#: boundary of the kept part is found in 4^LEVELS pieces at most).
LEVELS = 6
#: Margin kept from the boundary of the kept part, mm (far below any patch, above rounding).
MARGIN = 1e-9


def target_layers(
    surfaces: dict[str, Surface],
    target: TargetVolume,
    j: int,
    rough: RoughFace,
    where: str | None = None,
) -> list[RoughLayer]:
    """The rough layers of ``rough`` on ``target``: on a boolean solid, the layer on face
    ``rough.face`` (one per plane of a face of several planes; see the module docstring); on
    other solids one
    (:func:`score4.world.scene.make_layer`), or one per plane of a face made of flat facets in
    several planes (the ``nsides`` sides of a G4Polyhedra face, the planes of a tessellated
    mesh: :func:`score4.world.facets.plane_groups`)."""
    where = where or f"targets.{target.entry}.rough.{j}"
    shape = target.shape
    if isinstance(shape, BooleanShape):
        clip, leaf_target, leaf_rough, placed = _leaf(target, rough, where)
        try:
            layers = target_layers(surfaces, leaf_target, j, leaf_rough, where)
            narrow = _grown_wall_extent(clip, layers[0]) if rough.into else None
            if narrow is not None:  # laid out again on the part of the wall that is kept
                clip, leaf_target, leaf_rough, placed = _leaf(target, rough, where, narrow)
                layers = target_layers(surfaces, leaf_target, j, leaf_rough, where)
        except ConfigError as err:
            seen = "" if leaf_rough.face == clip.face else ", turned: the wall of a solid beside it"
            raise ConfigError(
                f"{err} (face {rough.face_name} of the {target.solid} is face {clip.face} of its "
                f"{clip.leaf.kind}{seen})"
            ) from None
        return _on_boolean(layers, target, rough, clip, placed, where)
    if shape is not None and isinstance(rough.face, str) and rough.face in shape.faces:
        groups = plane_groups(face_triangles(shape, rough.face))
        if len(groups) > 1:
            names = [v.surface for v in rough.variant_list]
            variants = [surfaces[n] for n in names]
            size = (variants[0].size_x, variants[0].size_y)
            layer = make_layer(surfaces, target, j, rough, where, groups[0], 0)
            out: list[RoughLayer] = [layer]
            for k, tris in enumerate(groups[1:], start=1):
                face = plane_face(rough.face_name, tris)
                out.append(
                    make_polygon_layer(target, rough, face, names, variants, size, where, tris, k)
                )
            return out
    return [make_layer(surfaces, target, j, rough, where)]


def _what(target: TargetVolume, rough: RoughFace) -> str:
    return f"face {rough.face_name} of {target.name!r} (a {target.solid})"


def _grown_wall_extent(clip: FaceClip, layer: RoughLayer) -> tuple[float, float] | None:
    """For an ``into`` layer on a cylinder or cone wall of a subtracted polycone
    (:func:`~score4.world.boolean_modes.polycone_wall`), the z range (the polycone's frame) of
    the wall once the polycone has grown by the layer's cut where that is shorter than the old
    wall's (a neighbouring cone's line, kept, meets the moved wall further along it, as a
    drill-tip cone does the bore above it); else None. The layer is then laid out on that part
    only: its shell (between the old wall and the grown one) ends on z planes within the
    grown wall's range, all in the grown hole."""
    if not clip.flipped or not isinstance(layer, CurvedRoughLayer):
        return None
    old = polycone_wall(clip.leaf, clip.face)
    if old is None:
        return None
    try:
        moved = clip.leaf.moved({clip.face: -into_depth(layer, True)})
    except ConfigError:  # (refused where the boolean is cut, in one line: cut_face)
        return None
    if moved is None:
        return None
    grown = polycone_wall(moved[0], clip.face)
    if grown is None:
        return None
    (was, _, c0), (now, _, c1) = old, grown
    assert isinstance(was, G4Tubs | G4Cons)
    assert isinstance(now, G4Tubs | G4Cons)
    c1 += float(moved[1][2])
    lo, hi = max(c0 - was.dz, c1 - now.dz), min(c0 + was.dz, c1 + now.dz)
    if lo <= c0 - was.dz + 1e-12 and hi >= c0 + was.dz - 1e-12:
        return None  # as long as before, or longer: the old wall's range
    return lo, hi


def _leaf(
    target: TargetVolume,
    rough: RoughFace,
    where: str,
    narrow: tuple[float, float] | None = None,
) -> tuple[FaceClip, TargetVolume, RoughFace, Transform]:
    """Where the layer on a boolean's face goes: the face's clip, the leaf solid as a target
    (a subtracted tube's wall turned: :func:`turned_wall`), the entry on the leaf's face, and the
    leaf's frame in the boolean's; one-line errors for what boolean layers refuse. ``narrow``:
    a z range (leaf frame) a turned wall is cut to as well (:func:`_grown_wall_extent`)."""
    shape = target.shape
    assert isinstance(shape, BooleanShape)
    name = rough.face_name
    what = _what(target, rough)
    try:
        clip = shape.face_clip(name)
    except ConfigError as err:
        raise ConfigError(f"{where}: {target.column}: {str(err).removeprefix('face: ')}") from None
    check_modes(rough, where, what, clip.leaf, clip.face, clip.flipped)  # boolean_modes
    area = float(shape.face_areas[name])
    if not area > 0:
        raise ConfigError(f"{where}: {what} lies nowhere on the solid's surface (area 0)")
    leaf, face, placed = clip.leaf, clip.face, clip.transform
    if clip.flipped and not flat_face(leaf, face):
        lo, hi = shape.bounding_box()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
        z = clip.transform.inverse_apply(corners)[:, 2]
        extent = (float(z.min()), float(z.max()))
        if narrow is not None:
            extent = (max(extent[0], narrow[0]), min(extent[1], narrow[1]))
        turned = turned_wall(leaf, face, extent)
        if turned is None and face in THETA:
            raise ConfigError(
                f"{where}: {what} is the theta cone {face} of a subtracted {leaf.kind} that "
                "is flat (at 90 degrees to the axis) or reaches the sphere's centre (rmin 0); "
                "score4 lays a layer on a theta cone as on a G4Cons's wall, which needs a cone "
                "of a non-zero radius at both ends; rough faces there are the sphere faces "
                "(outer, inner)"
            )
        if turned is None:
            raise ConfigError(
                f"{where}: {what} is the curved face {face} of a subtracted {leaf.kind}; rough "
                "curved faces of a subtracted solid are the walls of a G4Tubs or G4Cons, the "
                "cylinder and cone walls (seg_<i>) of a G4Polycone or G4GenericPolycone and the "
                "sphere faces (outer, inner) of a G4Orb or G4Sphere"
            )
        leaf, face, shift = turned
        placed = clip.transform @ Transform(np.eye(3), shift)
    leaf_target = replace(target, shape=leaf, transform=target.transform @ placed, exclude=())
    update: dict[str, object] = {"face": face}
    if clip.flipped and face == clip.face:  # a subtracted solid's flat face: laid out on its
        update["into"] = False  # face, then turned and moved by _on_boolean (into: outward)
    return clip, leaf_target, rough.model_copy(update=update), placed


def _on_boolean(
    layers: list[RoughLayer],
    target: TargetVolume,
    rough: RoughFace,
    clip: FaceClip,
    placed: Transform,
    where: str,
    joint: BooleanShape | None = None,
) -> list[RoughLayer]:
    """The layers laid out on the leaf's face (``layers``: one, or one per plane of a face of
    several planes), turned to the boolean's side, with only the cells proven on the boolean's
    surface kept (:func:`kept_cells`); a plane of a face of several planes with no such cell is
    left out (flat). Each layer's rough share is its cells' area over the boolean face's.
    With ``into`` the boolean is cut for this layer alone (:func:`cut_face`), or given cut for
    all its layers (``joint``, :func:`into_joint`)."""
    shape = target.shape
    assert isinstance(shape, BooleanShape)
    name, what = rough.face_name, _what(target, rough)
    base = BooleanFace(shape, name, clip, target.transform)
    out = []
    for layer in layers:
        if clip.flipped and not isinstance(layer, CurvedRoughLayer):
            _flip(layer)
            if rough.into:  # the subtracted solid grows: the base lies beyond its old face
                layer.frame = layer.frame.shifted(-layer.thickness)
        on, cut = base, clip
        if rough.into and joint is not None:
            on = BooleanFace(joint, name, joint.face_clip(name), target.transform)
            cut = on.clip
        elif rough.into:  # the face cut behind by the layer's thickness (boolean_modes)
            start = f"{where}: into: true on {what}"
            try:
                on = cut_face(base, into_depth(layer, clip.flipped), start)
            except ConfigError as err:  # a solid that cannot be moved so (Shape.moved)
                if str(err).startswith(start):
                    raise
                raise ConfigError(f"{start}: {err}") from None
            cut = on.clip
        kept = kept_cells(layer, cut, on, placed)
        if rough.into and clip.flipped and not isinstance(layer, CurvedRoughLayer):
            kept &= _in_grown_slab(layer, clip, on, target.transform)
        layer.mask = kept
        theta = clip.flipped and clip.face in THETA and isinstance(layer, CurvedRoughLayer)
        if theta:  # the sphere's faces meet the cone at right angles: rings in the shell only
            assert isinstance(layer, CurvedRoughLayer)
            assert isinstance(clip.leaf, G4Sphere)
            shift = clip.transform.inverse_apply(placed.translation[None])[0]
            theta_rims(layer, clip.leaf, shift)
            kept = layer.mask
        if not kept.any():
            if len(layers) > 1:
                continue
            px, py = layer.patch_size
            raise ConfigError(
                f"{where}: no whole patch of {px * 1e3:g} x {py * 1e3:g} um fits on the part of "
                f"{what} that lies on the solid's surface"
            )
        layer.config = rough
        layer.face_area = float(on.shape.face_areas[name])
        layer.on_boolean = on
        if isinstance(layer, CurvedRoughLayer):
            layer.pieces = envelope_pieces(layer, True) if theta else envelope_pieces(layer)
        if _meets_own_solid(layer, on) or (
            isinstance(layer, CurvedRoughLayer)
            and layer.pieces is not None
            and _pieces_in_solid(layer, cut, on) is not None
        ):
            _clear_of_the_solid(layer, cut, on, placed, where, what)
        check_replicas(layer, where, what)
        out.append(layer)
    if not out:
        px, py = layers[0].patch_size
        raise ConfigError(
            f"{where}: no whole patch of {px * 1e3:g} x {py * 1e3:g} um fits on the part of "
            f"{what} (face {clip.face} of a {clip.leaf.kind} in {len(layers)} planes) that lies "
            "on the solid's surface"
        )
    return out


def into_joint(scene: Scene, target: TargetVolume, where: str) -> None:
    """``into`` layers on faces of one constituent of a boolean ``target`` that share an edge
    (:func:`~score4.world.boolean_modes.joint_leaves`: a post's wall and top, or its wall and
    the disk's top it stands on), laid out again on their joint cut: on each such constituent
    as on a plain solid (:func:`~score4.world.scene.joint_layout`: a wall's layer ends where its
    neighbours' cuts meet it, down to the foot grown into the cut under it; a ring's cells and
    flat rest within the joint cut's face), and every layer on or under such a constituent on
    the boolean cut for all the target's layers (the solid Geant4 gets,
    :func:`~score4.world.boolean_modes.boolean_cuts`). Errors start with ``where``."""
    shape = target.shape
    if not isinstance(shape, BooleanShape):
        return
    layers = [r for r in scene.layers_of(target.name) if r.config.into]
    joint, involved = joint_leaves(layers, target, where)
    if not joint:
        return
    cuts = boolean_cuts(layers, shape)
    made: dict[str, tuple[FaceClip, TargetVolume, Transform, list[RoughLayer]]] = {}
    for face in involved:  # the leaf's layers made anew (as target_layers makes them)
        rough = next(r.config for r in layers if r.config.face_name == face)
        clip, leaf_target, leaf_rough, placed = _leaf(target, rough, where)
        fresh = target_layers(scene.surfaces, leaf_target, 0, leaf_rough, where)
        made[face] = (clip, leaf_target, placed, fresh)
    for path, feet in joint.items():
        own = {f: made[f] for f in involved if leaf_path(shape, f)[0] == path}
        leaf_target = next(iter(own.values()))[1]
        by_face = {f[len(path) :]: m[3][0] for f, m in own.items()}
        laid = joint_layout(leaf_target, by_face, where, feet)
        for f, m in own.items():
            layer = laid[f[len(path) :]]
            m[3][0] = layer
            cuts[f] = into_depth(layer, False)
    cut = cut_boolean(shape, cuts)
    for face in involved:  # on the boolean's side, their cells kept on the joint cut
        clip, _leaf_target, placed, fresh = made[face]
        old = [
            r for r in scene.layers if r.target.name == target.name and r.config.face_name == face
        ]
        new = _on_boolean(fresh, target, old[0].config, clip, placed, where, cut)
        at = scene.layers.index(old[0])
        scene.layers[:] = [r for r in scene.layers if not any(r is o for o in old)]
        scene.layers[at:at] = new


def _in_grown_slab(
    layer: RoughLayer, clip: FaceClip, on: BooleanFace, to_world: Transform
) -> np.ndarray:
    """The cells of a flat ``into`` layer on a face of a subtracted solid (grown by the layer's
    thickness along the face's normal, ``on``) whose whole column, from the grown face up to the
    old one, lies in the grown solid: the cells on both faces. The solid's other faces next to
    the slab are planes or cones (a Trd's sides, a cone's wall), so a cell on the slab's two
    faces is on every section between them. A ring narrows its envelope to the radii both faces
    cover (a cone's floor shrinks as it grows down)."""
    size = layer.patch_size
    centres = layer.cell_centres()
    if isinstance(layer, RingRoughLayer):
        old, grown = clip.leaf.face(clip.face), on.clip.leaf.face(clip.face)
        assert isinstance(old, AnnulusFace)
        assert isinstance(grown, AnnulusFace)
        lo, hi = max(old.rmin, grown.rmin, layer.rmin), min(old.rmax, grown.rmax, layer.rmax)
        layer.rmin, layer.rmax = lo, max(lo, hi)
        return ring_cells(centres, size, lo, hi)
    out = np.ones(centres.shape[:-1], dtype=bool) if layer.mask is None else layer.mask.copy()
    for solid in (clip.leaf, on.clip.leaf):
        to = to_world @ (clip.transform if solid is clip.leaf else on.clip.transform)
        world = to.apply(face_triangles(solid, clip.face).reshape(-1, 3))
        local = layer.frame.to_local(world).reshape(-1, 3, 3)
        height = layer.thickness if solid is clip.leaf else 0.0
        plane = np.abs(local[..., 2] - height) <= 1e-9 * max(float(np.abs(local).max()), 1.0)
        tri2d = ccw(local[plane.all(axis=1)][..., :2])
        scale = max(float(np.abs(tri2d).max()), 1.0) if len(tri2d) else 1.0
        out &= cells_inside(tri2d, centres, size, 1e-9 * scale)
    return out


def envelope_pieces(layer: CurvedRoughLayer, normal: bool = False) -> list[EnvelopePiece] | None:
    """The pieces (:class:`~score4.world.scene.EnvelopePiece`: ``(phi0, dphi, v0, v1,
    normal_ends)``) of the envelope of a cylinder, cone or sphere face whose kept cells leave
    part of the face flat (:attr:`CurvedRoughLayer.pieces`), or None where the face's whole
    shell is needed (every azimuth and every ring holds a kept cell; on a sphere, every cell is
    kept). With ``normal`` (a subtracted G4Sphere's theta cone, :func:`theta_rims`) every piece
    of a cone ends on its outer rings' band cones.

    Azimuths: the union over the rings of the kept cells' azimuth ranges; a run of cells that
    starts (ends) at a ring's first (last) cell reaches the face's phi edge (the flat rest of
    less than a cell that the rings leave there), so a fully kept ring covers the whole face
    (and, on a full circle, runs join across the seam). Along the generator: rings without a
    kept cell split the envelope. A piece ends on its outer rings' edges, or at the face's end
    where that ring is the face's first or last ring (on a sphere never). On a cylinder a
    ring's cells fill its band (half the rows' gap beyond the patch on each side). On a cone a
    ring's cells reach beyond its band (:func:`~score4.world.curved.cone_cell`: the corners
    moved out along the slanted normal), so each kept ring is bounded along the generator by
    its cells' own z range (:func:`~score4.world.curved.cone_ring_span`); kept rings whose
    spans do not meet split the envelope, and a piece ends where its outer rings' cells end;
    where the rings of such a run keep different azimuths, the pieces end on the rings' band
    cones (:func:`_wall_pieces`).

    On a sphere (:func:`sphere_pieces`) a piece is a G4Sphere segment: neighbouring rings'
    cells have their own azimuth grids (their steps differ), so a piece holds either a run of
    rings whose kept cells cover the same azimuths (whole rings, or runs reaching the face's
    phi edges) or one ring's run of kept cells, exactly: no piece covers a cell that is not
    kept (a sister standing where the face is cut away, another part of a union beside it)."""
    lay = layer.ring_layout
    face = lay.face
    has = np.asarray((layer.cell_variants >= 0).any(axis=1), dtype=bool)
    if isinstance(face, SphereFace):
        held = np.flatnonzero(lay.count > 0)  # (the rings at the poles hold none)
        if all((layer.cell_variants[j, : lay.count[j]] >= 0).all() for j in held):
            return None  # nothing of the face is cut: its whole zone
        return sphere_pieces(layer, has) or None
    pieces = _wall_pieces(layer, has, normal and abs(float(face.nrz[1])) > 1e-12)
    if normal:
        return pieces
    (_, _), (fv0, fv1) = face.extent
    if len(pieces) == 1:
        _phi0, dphi, v0, v1, _ = pieces[0]
        if dphi >= face.dphi - 1e-12 and v0 == fv0 and v1 == fv1:
            return None
    return pieces or None


def _ring_spans(layer: CurvedRoughLayer, j: int) -> list[tuple[float, float]]:
    """Azimuth ranges (from the face's phi0, in [0, dphi]) of ring ``j``'s runs of kept cells;
    a run starting (ending) at the ring's first (last) cell reaches the face's phi edge."""
    lay = layer.ring_layout
    face = lay.face
    n = int(lay.count[j])
    cols = np.flatnonzero(layer.cell_variants[j, :n] >= 0)
    if not len(cols):
        return []
    phi = lay.cell_phi(j)
    step = float(lay.step[j])
    breaks = np.flatnonzero(np.diff(cols) > 1)
    spans = []
    for a, b in zip(
        np.concatenate([[0], breaks + 1]), np.concatenate([breaks, [len(cols) - 1]]), strict=True
    ):
        lo = 0.0 if cols[a] == 0 else float(phi[cols[a]]) - step / 2 - face.phi0
        hi = face.dphi if cols[b] == n - 1 else float(phi[cols[b]]) + step / 2 - face.phi0
        spans.append((lo, hi))
    return spans


def _merged(face, spans: list[tuple[float, float]]) -> list[list[float]]:
    """Azimuth ranges (from the face's phi0) merged where they meet; on a full circle, the
    ranges at both phi edges joined across the seam."""
    merged: list[list[float]] = []
    for lo, hi in sorted(spans):
        if merged and lo <= merged[-1][1] + 1e-12:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    if (
        face.dphi >= 2 * np.pi - 1e-9
        and len(merged) > 1
        and merged[0][0] <= 1e-12
        and merged[-1][1] >= face.dphi - 1e-12
    ):
        last = merged.pop()  # joined across the seam
        merged[0] = [last[0] - face.dphi, merged[0][1]]
    return merged


def _wall_pieces(
    layer: CurvedRoughLayer, has: np.ndarray, normal: bool = False
) -> list[EnvelopePiece]:
    """:func:`envelope_pieces` of a cylinder or cone wall.

    On a cone whose rings in a run keep different azimuths (each ring has its own grid of
    azimuths, so a plane cutting the cone obliquely, as P00664B's cut does its tapers, leaves
    each ring a different range), the run's one piece would hold every ring's azimuths over its
    whole length, beyond the cells of the rings keeping fewer; there the pieces end on the
    rings' band cones instead (``normal_ends``: the cones of the face's normals between
    neighbouring rings, which their cells share, :func:`~score4.world.curved.cone_cell`), one
    per group of neighbouring rings keeping the same azimuths, each holding only its rings'
    cells (a part of the run's piece); with ``normal`` (a cone) always so."""
    lay = layer.ring_layout
    face = lay.face
    assert isinstance(face, RevolvedFace)
    nrings = len(lay.v)
    if abs(float(face.nrz[1])) <= 1e-12:  # a cylinder: rings without a kept cell split it
        runs, j = [], 0
        while j < nrings:
            if not has[j]:
                j += 1
                continue
            k = j
            while k + 1 < nrings and has[k + 1]:
                k += 1
            runs.append((j, k))
            j = k + 1
        span = None
    else:  # a cone: runs of kept rings whose cells' spans along the generator meet
        span = np.full((nrings, 2), np.nan)
        runs = []
        for i in np.flatnonzero(has).tolist():
            span[i] = cone_ring_span(lay, i, layer.thickness)
            if runs and span[i, 0] <= np.nanmax(span[runs[-1][0] : runs[-1][1] + 1, 1]):
                runs[-1] = (runs[-1][0], i)
            else:
                runs.append((i, i))
    (_, _), (fv0, fv1) = face.extent
    half = 0.5 * (lay.patch_size[1] + lay.row_gap)
    pieces: list[EnvelopePiece] = []
    for j0, j1 in runs:
        if span is None:  # the outer rings' bands (the face's ends beyond its end rings)
            v0 = fv0 if j0 == 0 else float(lay.v[j0]) - half
            v1 = fv1 if j1 == nrings - 1 else float(lay.v[j1]) + half
        else:  # the outer rings' cells' ends (the face's ends beyond the first and last ring)
            v0 = fv0 if j0 == 0 else float(np.nanmin(span[j0 : j1 + 1, 0]))
            v1 = fv1 if j1 == nrings - 1 else float(np.nanmax(span[j0 : j1 + 1, 1]))
        rings = {j: _merged(face, _ring_spans(layer, j)) for j in range(j0, j1 + 1) if has[j]}
        groups = [[j0, j1]]
        if normal or (
            span is not None and not all(_same_ranges(m, rings[j0]) for m in rings.values())
        ):
            groups = []  # rings keeping other azimuths than their neighbour: a piece each
            for j in sorted(rings):
                if groups and _same_ranges(rings[j], rings[groups[-1][1]]):
                    groups[-1][1] = j
                else:
                    groups.append([j, j])
        for g0, g1 in groups:
            if len(groups) == 1 and not normal:
                spans = [s for j in range(j0, j1 + 1) for s in _ring_spans(layer, j)]
                ends, a, b = False, v0, v1
            else:  # between the cones of normals through the group's outer rings' bands
                spans = [s for j in range(g0, g1 + 1) for s in _ring_spans(layer, j)]
                ends, a, b = True, float(lay.v[g0]) - half, float(lay.v[g1]) + half
            for lo, hi in _merged(face, spans):
                pieces.append(EnvelopePiece(face.phi0 + lo, min(hi - lo, 2 * np.pi), a, b, ends))
    return pieces


def sphere_pieces(layer: CurvedRoughLayer, has: np.ndarray) -> list[EnvelopePiece]:
    """:func:`envelope_pieces` of a sphere face: consecutive rings whose kept cells cover the
    same azimuth ranges (to 1e-12 rad: whole rings, runs reaching the face's phi edges) make
    one piece per range; a ring whose ranges differ from its neighbours' makes its own. A piece
    spans its rings' bands along the meridian (each ring's cells are G4Sphere segments between
    the polar-angle cones half the rows' gap beyond the patch, :func:`sphere_cell`, which meet
    the neighbouring rings'), and no further: the zone beyond the first and last kept rings
    (the rings at the poles hold no cells) may be cut away, where a sister may stand."""
    lay = layer.ring_layout
    face = lay.face
    half = 0.5 * (lay.patch_size[1] + lay.row_gap)
    groups: list[tuple[int, int, list[list[float]]]] = []  # (first ring, last ring, ranges)
    for j in np.flatnonzero(has).tolist():
        ranges = _merged(face, _ring_spans(layer, j))
        if groups and groups[-1][1] == j - 1 and _same_ranges(groups[-1][2], ranges):
            groups[-1] = (groups[-1][0], j, groups[-1][2])
        else:
            groups.append((j, j, ranges))
    pieces: list[EnvelopePiece] = []
    for j0, j1, ranges in groups:
        v0, v1 = float(lay.v[j0]) - half, float(lay.v[j1]) + half
        for lo, hi in ranges:
            pieces.append(EnvelopePiece(face.phi0 + lo, min(hi - lo, 2 * np.pi), v0, v1))
    return pieces


def _same_ranges(a: list[list[float]], b: list[list[float]]) -> bool:
    """Two lists of azimuth ranges are the same to 1e-12 rad."""
    return len(a) == len(b) and all(
        abs(x[0] - y[0]) <= 1e-12 and abs(x[1] - y[1]) <= 1e-12 for x, y in zip(a, b, strict=True)
    )


def turned_wall(
    leaf: Shape, face: str, extent: tuple[float, float]
) -> tuple[Shape, str, np.ndarray] | None:
    """The wall ``face`` of a subtracted G4Tubs, G4Cons, G4Orb or G4Sphere as the opposite wall
    of a solid beside it, whose outward normal is the boolean's (the bore a subtracted cylinder
    or cone leaves is the ``inner`` wall of a tube or cone whose inner radii are the subtracted
    solid's outer radii, a spherical cavity the ``inner`` face of a shell, not cut; a subtracted
    solid's ``inner`` wall is the ``outer`` wall of a full one), tubes and cones cut to
    ``extent`` (z range, leaf frame: where the boolean can be, so the layer's shell ends where
    the solid does), and the shift of its origin in the leaf's frame; None for other solids and
    faces."""
    if isinstance(leaf, G4Polycone | G4GenericPolycone) or face in ("theta_start", "theta_end"):
        wall = polycone_wall(leaf, face) if face not in THETA else theta_wall(leaf, face)
        if wall is None:
            return None
        leaf, face, centre = wall
        assert isinstance(leaf, G4Tubs | G4Cons)
        lo, hi = max(extent[0] - centre, -leaf.dz), min(extent[1] - centre, leaf.dz)
        if not hi > lo:
            return None
        seg = leaf.trimmed({"-z": lo + leaf.dz, "+z": leaf.dz - hi})
        assert seg is not None  # a G4Tubs or G4Cons is cut along z
        return seg[0], face, seg[1] + np.array([0.0, 0.0, centre])
    if face not in ("outer", "inner"):
        return None
    turned: Shape
    if isinstance(leaf, G4Orb):  # a spherical cavity's wall: the inner face of a shell
        return G4Sphere(leaf.r, 2 * leaf.r), "inner", np.zeros(3)
    if isinstance(leaf, G4Sphere):
        if face == "outer":
            return replace(leaf, rmin=leaf.rmax, rmax=2 * leaf.rmax), "inner", np.zeros(3)
        if leaf.rmin > 0:
            return replace(leaf, rmin=0.0, rmax=leaf.rmin), "outer", np.zeros(3)
        return None
    if isinstance(leaf, G4Tubs):
        if face == "outer":
            turned, name = replace(leaf, rmin=leaf.rmax, rmax=2 * leaf.rmax), "inner"
        elif leaf.rmin > 0:
            turned, name = replace(leaf, rmin=0.0, rmax=leaf.rmin), "outer"
        else:
            return None
    elif isinstance(leaf, G4Cons):
        if face == "outer":
            w = max(leaf.rmax1, leaf.rmax2)
            turned = replace(
                leaf, rmin1=leaf.rmax1, rmax1=leaf.rmax1 + w, rmin2=leaf.rmax2, rmax2=leaf.rmax2 + w
            )
            name = "inner"
        elif max(leaf.rmin1, leaf.rmin2) > 0:
            turned = replace(leaf, rmin1=0.0, rmax1=leaf.rmin1, rmin2=0.0, rmax2=leaf.rmin2)
            name = "outer"
        else:
            return None
    else:
        return None
    lo, hi = max(extent[0], -leaf.dz), min(extent[1], leaf.dz)
    if not hi > lo:
        return None
    cut = turned.trimmed({"-z": lo + leaf.dz, "+z": leaf.dz - hi})
    assert cut is not None  # a G4Tubs or G4Cons is cut along z
    return cut[0], name, cut[1]


THETA = ("theta_start", "theta_end")


def theta_wall(leaf: Shape, face: str) -> tuple[Shape, str, float] | None:
    """The theta cone ``face`` of a G4Sphere turned as :func:`polycone_wall` turns a polycone's
    cone wall: the wall of a G4Cons over the cone's z range (from ``rmin`` to ``rmax`` along
    its generator) on the side away from the sphere, the ``inner`` wall of a hollow G4Cons
    whose inner radii are the cone's where the sphere lies towards the axis, else the
    ``outer`` wall of a full one, and the z of its centre in the sphere's frame; None for other
    faces, for a cone at a right angle to the axis (a flat ring) and for a cone reaching the
    sphere's centre (it closes to a point)."""
    if not isinstance(leaf, G4Sphere) or face not in THETA:
        return None
    theta = leaf.stheta if face == "theta_start" else leaf.stheta + leaf.dtheta
    s, c = float(np.sin(theta)), float(np.cos(theta))
    if abs(c) <= 1e-12 or leaf.rmin <= 0:
        return None
    (r1, z1), (r2, z2) = sorted([(leaf.rmin * s, leaf.rmin * c), (leaf.rmax * s, leaf.rmax * c)],
                                key=lambda p: p[1])  # fmt: skip
    dz, phi = (z2 - z1) / 2, (leaf.sphi, leaf.dphi)
    # the sphere's outward normal's radial part: > 0 where the sphere lies towards the axis
    n_r = c if face == "theta_end" else -c
    if n_r > 0:
        w = max(r1, r2)
        return G4Cons(r1, r1 + w, r2, r2 + w, dz, *phi), "inner", (z1 + z2) / 2
    return G4Cons(0.0, r1, 0.0, r2, dz, *phi), "outer", (z1 + z2) / 2


def theta_rims(layer: CurvedRoughLayer, leaf: G4Sphere, shift: np.ndarray) -> None:
    """On the turned theta cone of a subtracted G4Sphere (:func:`theta_wall`) the layer lies in
    the sphere's shell next to the cone, whose sphere faces meet the cone at right angles; an
    envelope ending on z planes would leave the shell there. Its pieces end on the rings' band
    cones (the cones of the face's normals, :attr:`EnvelopePiece.normal_ends`), and only rings
    whose band lies in the shell keep their cells: the band's normal line at distance ``s``
    from the centre along the generator reaches ``sqrt(s^2 + h^2)`` at height ``h`` above the
    face, so a band from ``s0`` to ``s1`` lies in the shell when ``s0 >= rmin`` and
    ``s1^2 + t^2 <= rmax^2`` (``t``: the layer's thickness). ``shift``: the turned cone's centre
    in the sphere's frame."""
    lay = layer.ring_layout
    face = lay.face
    assert isinstance(face, RevolvedFace)
    half = 0.5 * (lay.patch_size[1] + lay.row_gap)
    t = layer.thickness
    ends = [face.point(np.zeros(len(lay.v)), lay.v + d) for d in (-half, half)]
    s0, s1 = (np.linalg.norm(e + shift, axis=1) for e in ends)
    lo, hi = np.minimum(s0, s1), np.maximum(s0, s1)
    fits = (lo >= leaf.rmin - 1e-12) & (hi * hi + t * t <= leaf.rmax * leaf.rmax)
    assert layer.mask is not None
    layer.mask = layer.mask & fits[:, None]


def _flip(layer: RoughLayer) -> None:
    """Turn a flat layer over (normal reversed, y reversed: the frame stays right-handed); the
    cell grid is centred on the frame, so rows swap."""
    f = layer.frame
    layer.frame = FaceFrame(f.centre, f.rotation @ np.diag([1.0, -1.0, -1.0]), f.size)
    if layer.mask is not None:
        layer.mask = layer.mask[::-1].copy()
    if isinstance(layer, PolygonRoughLayer):
        layer.outline = ccw(layer.outline * np.array([1.0, -1.0]))
        layer.__dict__.pop("prism", None)


def _certify(centres, half_u, half_v, point, bound, margin) -> np.ndarray:
    """True for the cells (centres (n, 2) in face parameters, half widths ``half_u``,
    ``half_v`` (n,)) proven on the boolean's surface: ``point(uv)`` gives world points,
    ``bound(uv, hu, hv)`` a bound of the distance from a centre to its cell's points,
    ``margin(world, cells)`` the clip margin (``cells``: the index of the cell of each
    point)."""
    n = len(centres)
    ok = np.ones(n, dtype=bool)
    pending = np.arange(n)
    uv, hu, hv = centres.copy(), half_u.copy(), half_v.copy()
    for level in range(LEVELS + 1):
        if not len(pending):
            break
        m = margin(point(uv), pending)
        r = bound(uv, hu, hv)
        proven = m > r + MARGIN
        out = m <= MARGIN  # a point of the cell off the surface (or on its edge): not kept
        ok[np.unique(pending[out])] = False
        undecided = ~proven & ~out
        if level == LEVELS:
            ok[np.unique(pending[undecided])] = False
            break
        keep = undecided & ok[pending]
        pending, uv, hu, hv = pending[keep], uv[keep], hu[keep] / 2, hv[keep] / 2
        offsets = np.array([[-1, -1], [1, -1], [-1, 1], [1, 1]], float)
        uv = (uv[:, None, :] + offsets[None] * np.column_stack([hu, hv])[:, None, :]).reshape(-1, 2)
        pending, hu, hv = np.repeat(pending, 4), np.repeat(hu, 4), np.repeat(hv, 4)
    return ok


def kept_cells(
    layer: RoughLayer,
    clip: FaceClip,
    on: BooleanFace,
    placed: Transform | None = None,
    height: float = 0.0,
) -> np.ndarray:
    """The layer's cells (``(ny, nx)``) that hold a patch and lie wholly on the boolean's
    surface (``placed``: the frame of a curved layer's solid in the boolean's, by default the
    leaf's, ``clip.transform``); with ``height`` (a flat layer) the whole column of the cell up
    to that height above the face is proven on the kept side of every cutting solid (outside
    the other part of a union)."""
    base = layer.cell_variants >= 0
    rows, cols = np.nonzero(base)
    px, py = layer.patch_size

    if isinstance(layer, CurvedRoughLayer):
        lay = layer.ring_layout
        face = lay.face
        phi = lay.phi_mid + (cols - (lay.count[rows] - 1) / 2) * lay.step[rows]  # cell_phi
        centres = np.column_stack([phi, lay.v[rows]])
        half_u, half_v = lay.step[rows] / 2, np.full(len(rows), py / 2)
        to_boolean = clip.transform if placed is None else placed  # where the face's points are

        def point(uv: np.ndarray) -> np.ndarray:
            return face.point(uv[:, 0], uv[:, 1])

        def bound(uv: np.ndarray, hu: np.ndarray, hv: np.ndarray) -> np.ndarray:
            # along the generator (a meridian), then along the circle at the larger radius (on
            # a sphere at most the sphere's: a cell may straddle the equator)
            if isinstance(face, SphereFace):
                return hv + face.sphere_radius * hu
            r = np.maximum(face.radius(uv[:, 1] - hv), face.radius(uv[:, 1] + hv))
            return hv + np.abs(r) * hu

    else:
        cc = layer.patch_map.cell_centres()
        centres = cc[rows, cols] if len(rows) else np.zeros((0, 2))
        half_u, half_v = np.full(len(rows), px / 2), np.full(len(rows), py / 2)
        to_boolean = layer.frame.transform.relative_to(on.transform)

        def point(uv: np.ndarray) -> np.ndarray:  # the middle of the column
            return np.column_stack([uv, np.full(len(uv), height / 2)])

        def bound(uv: np.ndarray, hu: np.ndarray, hv: np.ndarray) -> np.ndarray:
            if not height:
                return np.hypot(hu, hv)
            return np.sqrt(hu * hu + hv * hv + height * height / 4)

    r, t = to_boolean.rotation, to_boolean.translation
    boxes = _cell_boxes(layer, centres, half_u, half_v, height)
    none = np.zeros(len(rows), dtype=bool)
    passed = [none if boxes is None else _clear_by_boxes(boxes, to_boolean, *c) for c in clip.clips]

    def margin(local: np.ndarray, cells: np.ndarray) -> np.ndarray:
        # to_boolean.apply written out: a BLAS product of (n, 3) by (3, 3) is slow where the
        # cores are shared
        q = t + local[:, :1] * r[:, 0] + local[:, 1:2] * r[:, 1] + local[:, 2:] * r[:, 2]
        # FaceClip.margin, less the cutting solids the cell's bounding box already clears
        out = np.full(len(q), np.inf)
        for (shape, transform, inside), done in zip(clip.clips, passed, strict=True):
            sel = ~done[cells]
            if not sel.any():
                continue
            p = q[sel]
            if np.array_equal(transform.rotation, np.eye(3)):  # a shift (most cuts)
                p = p - transform.translation
            else:
                p = transform.inverse_apply(p)
            d = shape.signed_distance(p)
            out[sel] = np.minimum(out[sel], -d if inside else d)
        return out

    ok = _certify(centres, half_u, half_v, point, bound, margin)
    out = np.zeros_like(base)
    out[rows[ok], cols[ok]] = True
    return out


def _cell_boxes(
    layer: RoughLayer,
    centres: np.ndarray,
    half_u: np.ndarray,
    half_v: np.ndarray,
    height: float,
) -> np.ndarray | None:
    """The 8 corners (n, 8, 3) of a box holding each cell (with ``height``, its column), in the
    frame of the points kept_cells maps to the boolean's: the face frame of a flat layer, the
    solid's frame of a cylinder or cone wall (z from the generator's ends, x and y from the
    arc's extremes at both radii); None on a sphere (not needed there)."""
    u, v = centres[:, 0], centres[:, 1]
    if isinstance(layer, CurvedRoughLayer):
        face = layer.ring_layout.face
        if isinstance(face, SphereFace):
            return None
        za = face.point(u, v - half_v)[:, 2]
        zb = face.point(u, v + half_v)[:, 2]
        ra, rb = np.abs(face.radius(v - half_v)), np.abs(face.radius(v + half_v))
        lo_r, hi_r = np.minimum(ra, rb), np.maximum(ra, rb)
        phi0, phi1 = u - half_u, u + half_u

        def extremes(shift: float) -> tuple[np.ndarray, np.ndarray]:
            # least and largest cos(phi - shift) over [phi0, phi1]
            a, b = np.cos(phi0 - shift), np.cos(phi1 - shift)
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            k0 = np.ceil((phi0 - shift) / np.pi)  # multiples of pi inside the range
            k1 = np.floor((phi1 - shift) / np.pi)
            has_even = (k1 >= k0) & ((k1 > k0) | (k0 % 2 == 0))
            has_odd = (k1 >= k0) & ((k1 > k0) | (k0 % 2 == 1))
            return np.where(has_odd, -1.0, lo), np.where(has_even, 1.0, hi)

        cx0, cx1 = extremes(0.0)
        sy0, sy1 = extremes(np.pi / 2)
        x0 = np.minimum(lo_r * cx0, hi_r * cx0)
        x1 = np.maximum(lo_r * cx1, hi_r * cx1)
        y0 = np.minimum(lo_r * sy0, hi_r * sy0)
        y1 = np.maximum(lo_r * sy1, hi_r * sy1)
        z0, z1 = np.minimum(za, zb), np.maximum(za, zb)
    else:
        x0, x1, y0, y1 = u - half_u, u + half_u, v - half_v, v + half_v
        z0, z1 = np.zeros(len(u)), np.full(len(u), height)
    xs, ys, zs = np.stack([x0, x1], 1), np.stack([y0, y1], 1), np.stack([z0, z1], 1)
    i, j, k = (g.ravel() for g in np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij"))
    return np.stack([xs[:, i], ys[:, j], zs[:, k]], -1)


def _clear_by_boxes(
    boxes: np.ndarray,
    to_boolean: Transform,
    shape: Shape,
    transform: Transform,
    inside: bool,
) -> np.ndarray:
    """True for the cells whose box (:func:`_cell_boxes`) alone proves them on the kept side
    of the cutting solid ``shape`` (placed by ``transform`` in the boolean's frame): outside it,
    the box and the solid's bounding box share no inner point (they may touch: a union's
    seam); inside it (a G4Box, its own bounding box), the box lies in the solid (it may reach
    its faces: a bore's ends). Cells that touch the solid's boundary cannot be proven by
    distances alone."""
    n = len(boxes)
    pts = transform.inverse_apply(to_boolean.apply(boxes.reshape(-1, 3))).reshape(n, 8, 3)
    lo, hi = pts.min(axis=1), pts.max(axis=1)
    try:
        slo, shi = (np.asarray(b, float) for b in shape.bounding_box())
    except NotImplementedError:  # a shape without a bounding box: distances only
        return np.zeros(n, dtype=bool)
    if not inside:
        return np.asarray(((hi <= slo + MARGIN) | (lo >= shi - MARGIN)).any(axis=1))
    if isinstance(shape, G4Box):
        return np.asarray(((lo >= slo - MARGIN) & (hi <= shi + MARGIN)).all(axis=1))
    return np.zeros(n, dtype=bool)


def fit_cells(layers: list[RoughLayer], where: str = "targets") -> None:
    """Layers whose envelope is the prism of their kept cells (a face partly covered by another
    part of a union, :func:`_clear_of_the_solid`) give way to the other layers of the same
    volume: a cell keeps its patch only where its whole column is proven clear of every other
    layer's envelope (a lower bound of the distance from the column to it: to a flat layer's
    envelope box, to a cylinder or cone wall's generator less that layer's thickness, to a
    sphere face less it), so a rough wall rising from such a face (a post's wall on a disk)
    leaves the cells along its foot flat. Exact, not sampled: a layer a few um thick cannot
    slip between the clearance check's points."""
    for layer in layers:
        others = [o for o in layers if o is not layer]
        if not layer.cells_envelope or not others or layer.mask is None:
            continue
        clear = _column_cells(
            layer, layer.frame.to_world, _margin([_distance_bound(o) for o in others])
        )
        layer.mask = layer.mask & clear
        if not layer.mask.any():
            px, py = layer.patch_size
            raise ConfigError(
                f"{where}.{layer.target.entry}.rough: no whole patch of {px * 1e3:g} x "
                f"{py * 1e3:g} um fits on face {layer.config.face_name} of "
                f"{layer.target.name!r} clear of its other parts and of their rough layers"
            )


def _margin(bounds: list) -> Callable[[np.ndarray], np.ndarray]:
    """The least of the distance bounds ``bounds`` at world points."""

    def margin(world: np.ndarray) -> np.ndarray:
        return np.asarray(np.min([b(world) for b in bounds], axis=0))

    return margin


def _distance_bound(layer: RoughLayer) -> Callable[[np.ndarray], np.ndarray]:
    """A function giving, for world points, a lower bound of their distance to ``layer``'s
    envelope (<= 0 inside or near it)."""
    if isinstance(layer, CurvedRoughLayer):
        face, t, to_local = layer.ring_layout.face, layer.thickness, layer.target.to_local
        if isinstance(face, SphereFace):
            centre_r = face.sphere_radius

            def sphere(world: np.ndarray) -> np.ndarray:
                return np.asarray(np.abs(np.linalg.norm(to_local(world), axis=1) - centre_r) - t)

            return sphere
        (r1, z1), (r2, z2) = face.rz1, face.rz2

        def wall(world: np.ndarray) -> np.ndarray:
            # in the (r, z) half-plane: the distance to the generator bounds the distance to
            # the wall at any azimuth
            q = to_local(world)
            rho, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2]
            dr, dz = r2 - r1, z2 - z1
            s = np.clip(((rho - r1) * dr + (z - z1) * dz) / (dr * dr + dz * dz), 0.0, 1.0)
            return np.asarray(np.hypot(rho - r1 - s * dr, z - z1 - s * dz) - t)

        return wall
    box = layer.envelope_box()

    def flat(world: np.ndarray) -> np.ndarray:
        q = box.transform.inverse_apply(world)
        return np.asarray(np.linalg.norm(np.maximum(np.abs(q) - box.half, 0.0), axis=1))

    return flat


def _column_cells(
    layer: RoughLayer,
    to_world: Callable[[np.ndarray], np.ndarray],
    margin: Callable[[np.ndarray], np.ndarray],
) -> np.ndarray:
    """The kept cells of a flat layer whose whole column (the cell up to the layer's thickness)
    has ``margin`` (of world points) proven positive (:func:`_certify`)."""
    assert layer.mask is not None
    rows, cols = np.nonzero(layer.mask)
    px, py = layer.patch_size
    centres = layer.cell_centres()[rows, cols]
    height = layer.thickness

    def point(uv: np.ndarray) -> np.ndarray:
        return np.column_stack([uv, np.full(len(uv), height / 2)])

    def bound(uv: np.ndarray, hu: np.ndarray, hv: np.ndarray) -> np.ndarray:
        return np.sqrt(hu * hu + hv * hv + height * height / 4)

    ok = _certify(
        centres,
        np.full(len(rows), px / 2),
        np.full(len(rows), py / 2),
        point,
        bound,
        lambda local, _cells: margin(to_world(local)),
    )
    out = np.zeros_like(layer.mask)
    out[rows[ok], cols[ok]] = True
    return out


def _meets_own_solid(layer: RoughLayer, on: BooleanFace) -> bool:
    """True when points of the layer's envelope lie inside the boolean solid (a face partly
    covered by another part of a union puts them there): a grid of its points first, then a
    certified search where the envelope meets another part of a union the face is in
    (:func:`_in_union_parts`): :func:`~score4.world.clearance.flat_meet` on a flat layer's
    envelope down to :data:`~score4.world.clearance.RESOLUTION_SHARE` of the layer's
    thickness, :func:`_pieces_in_solid` on a curved layer's shell (whose caller searches an
    envelope in pieces so)."""
    from . import clearance

    if isinstance(layer, CurvedRoughLayer):
        points = layer.shell_points()
    else:
        points = layer.envelope_points()
    codes = on.shape.inside(on.transform.inverse_apply(points))
    if (codes == INSIDE).any():
        return True
    if isinstance(layer, CurvedRoughLayer):  # (an envelope in pieces: searched by the caller)
        return layer.pieces is None and _pieces_in_solid(layer, on.clip, on) is not None
    depth = _in_union_parts(on.clip, on)
    if depth is None:
        return False
    resolution = clearance.RESOLUTION_SHARE * layer.thickness
    return clearance.flat_meet(layer, depth, resolution, "the solid's other parts") is not None


def _in_union_parts(clip: FaceClip, on: BooleanFace) -> Callable[[np.ndarray], np.ndarray] | None:
    """How deep world points lie in the boolean solid and in another part of a union the face
    is in (positive inside, changing by no more than the distance a point moves), or None
    when the face is in no union. A layer's envelope lies outside the face's own constituent,
    so it is in the solid only inside such a part; a solid subtracted beside the face
    (:func:`_clip_operations`) is a hole, never material."""
    ops = _clip_operations(on.shape, on.face)
    if len(ops) != len(clip.clips):  # (a face clip of another make: every part from outside)
        ops = ["union"] * len(clip.clips)
    cutters = [
        (shape, transform)
        for (shape, transform, inside), op in zip(clip.clips, ops, strict=True)
        if not inside and op == "union"
    ]
    if not cutters:
        return None

    def depth(world: np.ndarray) -> np.ndarray:
        q = on.transform.inverse_apply(world)
        in_cut = np.max([-s.signed_distance(t.inverse_apply(q)) for s, t in cutters], axis=0)
        return np.asarray(np.minimum(-on.shape.signed_distance(q), in_cut))

    return depth


def _pieces_in_solid(layer: CurvedRoughLayer, clip: FaceClip, on: BooleanFace) -> np.ndarray | None:
    """A world point of a curved layer's envelope pieces inside the boolean solid and inside
    another part of a union the face is in (:func:`_in_union_parts`), or None: an exact search
    (:func:`~score4.world.clearance.shell_search`) down to half the layer's thickness, as
    between two layers (a piece ending on another part's face touches it all round). The
    search stays where the envelope meets such a part: the face itself lies on the solid's
    surface, where a search against the whole solid would not end. A solid subtracted beside
    the face is not searched: where its wall is the face (a groove cut around a rod) the
    search could not drop the cells along it and gave up."""
    from .clearance import shell_search

    depth = _in_union_parts(clip, on)
    if depth is None:
        return None
    return shell_search(layer, depth, layer.thickness / 2, "the solid's other parts")


def _clip_operations(shape: Shape, name: str) -> list[str]:
    """The operation of each boolean on the way to face ``name``, in the order of its clips
    (:meth:`BooleanShape.face_clip`: the innermost first): a clip from outside is another part
    of a union (``union``: material) or a solid subtracted from the face's side
    (``subtraction``: a hole)."""
    while isinstance(shape, PlacedShape):
        shape = shape.shape
    if not isinstance(shape, BooleanShape):
        return []
    part, rest = name.split(".", 1)
    inner = _clip_operations(shape.first if part == "first" else shape.second, rest)
    return [*inner, shape.operation]


def _clear_of_the_solid(
    layer: RoughLayer,
    clip: FaceClip,
    on: BooleanFace,
    placed: Transform,
    where: str,
    what: str,
) -> None:
    """A flat layer whose envelope runs into the solid (a face partly covered by another part of
    a union): only the cells whose whole column (the cell times the layer's thickness) is proven
    clear of the solids cutting the face keep their patch (:func:`kept_cells` with the
    thickness), and the envelope becomes the prism of those cells (``cells_envelope``); the
    cells the other part covers or meets stay flat (``rough_shares``). A curved layer's
    envelope already holds only its kept cells' azimuth ranges and runs of rings
    (:func:`envelope_pieces`); it is refused when that still runs into the solid."""
    thick = f"{layer.thickness * 1e3:.4g} um thick"
    if isinstance(layer, CurvedRoughLayer):
        raise ConfigError(
            f"{where}: the rough layer on {what} ({thick}) runs into the solid itself (another "
            "part of the boolean covers or meets that face); its envelope holds the kept "
            "cells' azimuth ranges and runs of rings, and these must lie wholly outside the "
            "solid's other parts"
        )
    assert layer.mask is not None
    if layer.config.native_layout == "replicas":
        raise ConfigError(
            f"{where}: native_layout replicas fills every cell; {what} is partly covered by "
            "another part of the solid, so its envelope holds only the cells clear of it: take "
            "auto, nested or placements"
        )
    layer.mask = layer.mask & kept_cells(layer, clip, on, placed, height=layer.thickness)
    layer.cells_envelope = True
    if not layer.mask.any():
        px, py = layer.patch_size
        raise ConfigError(
            f"{where}: no whole patch of {px * 1e3:g} x {py * 1e3:g} um with its layer "
            f"({thick}) fits on the part of {what} clear of the solid's other parts"
        )
    if _meets_own_solid(layer, on):
        raise ConfigError(
            f"{where}: the rough layer on {what} ({thick}) runs into the solid itself (another "
            "part of the boolean covers or meets that face); choose a face the layer can lie on "
            "outside the solid"
        )
