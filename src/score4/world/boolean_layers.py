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

The wall of a subtracted G4Tubs (a bore) faces the other way than the tube's: its layer is laid
out as on the opposite wall of a tube beside it (:func:`turned_wall`: the bore is the ``inner``
wall of a tube whose inner radius is the cylinder's), cut along the axis to where the boolean
can be, so the layer lies in the bore and its shell ends where the solid does.

Refused, in one line each (:mod:`score4.world.boolean_modes` says why): ``into: true`` other
than on flat faces of a G4Box or G4Tubs constituent and on bores, ``tiling: portal``,
``native_layout: replicas`` where a cell holds no patch;
a curved face of a subtracted solid other than a G4Tubs wall (cones, spheres); a face of a solid
made of flat facets in several planes; a layer whose
envelope runs into the solid itself (a face partly covered by another part of a union, or whose
envelope leaves a cut). Steps and activeness measure these layers through the boolean's
constituents (:mod:`score4.world.boolean_distance`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from score4.errors import ConfigError
from score4.inputs.config import RoughFace
from score4.shapes import BooleanShape, G4Tubs, Shape, Transform
from score4.shapes.base import INSIDE
from score4.shapes.boolean import FaceClip
from score4.shapes.faces import PlaneFace, SphereFace
from score4.surface.rough import Surface

from .boolean_modes import check_modes, check_replicas, cut_face, into_depth
from .facets import ccw, face_triangles, plane_face, plane_groups
from .scene import (
    BooleanFace,
    CurvedRoughLayer,
    FaceFrame,
    PolygonRoughLayer,
    RingRoughLayer,
    RoughLayer,
    TargetVolume,
    make_layer,
    make_polygon_layer,
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
    """The rough layers of ``rough`` on ``target``: on a boolean solid, the one layer on face
    ``rough.face`` (see the module docstring); on other solids one
    (:func:`score4.world.scene.make_layer`), or one per plane of a face made of flat facets in
    several planes (the ``nsides`` sides of a G4Polyhedra face, the planes of a tessellated
    mesh: :func:`score4.world.facets.plane_groups`)."""
    where = where or f"targets.{target.entry}.rough.{j}"
    shape = target.shape
    if isinstance(shape, BooleanShape):
        clip, leaf_target, leaf_rough, placed = _leaf(target, rough, where)
        try:
            layers = target_layers(surfaces, leaf_target, j, leaf_rough, where)
        except ConfigError as err:
            seen = "" if leaf_rough.face == clip.face else ", turned: the wall of a solid beside it"
            raise ConfigError(
                f"{err} (face {rough.face_name} of the {target.solid} is face {clip.face} of its "
                f"{clip.leaf.kind}{seen})"
            ) from None
        return [_on_boolean(layers, target, rough, clip, placed, where)]
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


def _leaf(
    target: TargetVolume, rough: RoughFace, where: str
) -> tuple[FaceClip, TargetVolume, RoughFace, Transform]:
    """Where the layer on a boolean's face goes: the face's clip, the leaf solid as a target
    (a subtracted tube's wall turned: :func:`turned_wall`), the entry on the leaf's face, and the
    leaf's frame in the boolean's; one-line errors for what boolean layers refuse."""
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
    if isinstance(clip.leaf.face(clip.face), SphereFace):
        raise ConfigError(
            f"{where}: {what} is the sphere face {clip.face} of a {clip.leaf.kind}; rough faces "
            "of a boolean are flat faces and cylinder or cone walls"
        )
    leaf, face, placed = clip.leaf, clip.face, clip.transform
    if clip.flipped and not isinstance(leaf.face(face), PlaneFace):
        lo, hi = shape.bounding_box()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
        z = clip.transform.inverse_apply(corners)[:, 2]
        turned = turned_wall(leaf, face, (float(z.min()), float(z.max())))
        if turned is None:
            raise ConfigError(
                f"{where}: {what} is the curved face {face} of a subtracted {leaf.kind}; rough "
                "curved faces of a subtracted solid are the walls of a G4Tubs"
            )
        leaf, face, shift = turned
        placed = clip.transform @ Transform(np.eye(3), shift)
    leaf_target = replace(target, shape=leaf, transform=target.transform @ placed, exclude=())
    return clip, leaf_target, rough.model_copy(update={"face": face}), placed


def _on_boolean(
    layers: list[RoughLayer],
    target: TargetVolume,
    rough: RoughFace,
    clip: FaceClip,
    placed: Transform,
    where: str,
) -> RoughLayer:
    """The layer laid out on the leaf's face (``layers``), turned to the boolean's side, with
    only the cells proven on the boolean's surface kept (:func:`kept_cells`)."""
    shape = target.shape
    assert isinstance(shape, BooleanShape)
    name, what = rough.face_name, _what(target, rough)
    if len(layers) != 1:
        raise ConfigError(
            f"{where}: {what} is face {clip.face} of a {clip.leaf.kind} in {len(layers)} planes; "
            "rough faces of a boolean are faces of one plane or of revolution"
        )
    layer = layers[0]
    if clip.flipped and not isinstance(layer, CurvedRoughLayer):
        _flip(layer)
    on = BooleanFace(shape, name, clip, target.transform)
    if rough.into:  # the face cut behind by the layer's thickness (boolean_modes)
        on = cut_face(on, into_depth(layer))
        clip = on.clip
    kept = kept_cells(layer, clip, on, placed)
    layer.mask = kept
    if not kept.any():
        px, py = layer.patch_size
        raise ConfigError(
            f"{where}: no whole patch of {px * 1e3:g} x {py * 1e3:g} um fits on the part of "
            f"{what} that lies on the solid's surface"
        )
    check_replicas(layer, where, what)
    layer.config = rough
    layer.face_area = float(on.shape.face_areas[name])
    layer.on_boolean = on
    _check_own_solid(layer, on, where, what)
    return layer


def turned_wall(
    leaf: Shape, face: str, extent: tuple[float, float]
) -> tuple[Shape, str, np.ndarray] | None:
    """The wall ``face`` of a subtracted G4Tubs as the opposite wall of a tube beside it, whose
    outward normal is the boolean's (the bore a subtracted cylinder leaves is the ``inner`` wall
    of a tube whose inner radius is the cylinder's; a subtracted tube's ``inner`` wall is the
    ``outer`` wall of a full cylinder), cut to ``extent`` (z range, leaf frame: where the
    boolean can be, so the layer's shell ends where the solid does), and the shift of its origin
    in the leaf's frame; None for other solids and faces."""
    if not isinstance(leaf, G4Tubs) or face not in ("outer", "inner"):
        return None
    if face == "outer":
        turned, name = replace(leaf, rmin=leaf.rmax, rmax=2 * leaf.rmax), "inner"
    elif leaf.rmin > 0:
        turned, name = replace(leaf, rmin=0.0, rmax=leaf.rmin), "outer"
    else:
        return None
    lo, hi = max(extent[0], -leaf.dz), min(extent[1], leaf.dz)
    if not hi > lo:
        return None
    cut = turned.trimmed({"-z": lo + leaf.dz, "+z": leaf.dz - hi})
    assert cut is not None  # a G4Tubs is cut along z
    return cut[0], name, cut[1]


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
    ``margin(world)`` the clip margin."""
    n = len(centres)
    ok = np.ones(n, dtype=bool)
    pending = np.arange(n)
    uv, hu, hv = centres.copy(), half_u.copy(), half_v.copy()
    for level in range(LEVELS + 1):
        if not len(pending):
            break
        m = margin(point(uv))
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
    layer: RoughLayer, clip: FaceClip, on: BooleanFace, placed: Transform | None = None
) -> np.ndarray:
    """The layer's cells (``(ny, nx)``) that hold a patch and lie wholly on the boolean's
    surface (``placed``: the frame of a curved layer's solid in the boolean's, by default the
    leaf's, ``clip.transform``)."""
    base = layer.cell_variants >= 0
    rows, cols = np.nonzero(base)
    px, py = layer.patch_size

    if isinstance(layer, CurvedRoughLayer):
        lay = layer.ring_layout
        face = lay.face
        assert not isinstance(face, SphereFace)  # a boolean's sphere faces stay refused
        phi = lay.phi_mid + (cols - (lay.count[rows] - 1) / 2) * lay.step[rows]  # cell_phi
        centres = np.column_stack([phi, lay.v[rows]])
        half_u, half_v = lay.step[rows] / 2, np.full(len(rows), py / 2)
        to_boolean = clip.transform if placed is None else placed  # where the face's points are

        def point(uv: np.ndarray) -> np.ndarray:
            return face.point(uv[:, 0], uv[:, 1])

        def bound(uv: np.ndarray, hu: np.ndarray, hv: np.ndarray) -> np.ndarray:
            # along the generator, then along the circle at the larger radius
            r = np.maximum(face.radius(uv[:, 1] - hv), face.radius(uv[:, 1] + hv))
            return hv + np.abs(r) * hu

    else:
        cc = layer.patch_map.cell_centres()
        centres = cc[rows, cols] if len(rows) else np.zeros((0, 2))
        half_u, half_v = np.full(len(rows), px / 2), np.full(len(rows), py / 2)
        to_boolean = layer.frame.transform.relative_to(on.transform)

        def point(uv: np.ndarray) -> np.ndarray:
            return np.column_stack([uv, np.zeros(len(uv))])

        def bound(uv: np.ndarray, hu: np.ndarray, hv: np.ndarray) -> np.ndarray:
            return np.hypot(hu, hv)

    r, t = to_boolean.rotation, to_boolean.translation

    def margin(local: np.ndarray) -> np.ndarray:
        # to_boolean.apply written out: a BLAS product of (n, 3) by (3, 3) is slow where the
        # cores are shared
        q = t + local[:, :1] * r[:, 0] + local[:, 1:2] * r[:, 1] + local[:, 2:] * r[:, 2]
        return clip.margin(q)

    ok = _certify(centres, half_u, half_v, point, bound, margin)
    out = np.zeros_like(base)
    out[rows[ok], cols[ok]] = True
    return out


def _check_own_solid(layer: RoughLayer, on: BooleanFace, where: str, what: str) -> None:
    """The layer's envelope must stay out of the boolean solid (a face partly covered by another
    part of a union would put it inside)."""
    if isinstance(layer, CurvedRoughLayer):
        points = layer.shell_points()
    elif isinstance(layer, PolygonRoughLayer | RingRoughLayer):
        points = layer.envelope_points()
    else:
        points = layer.envelope_box().grid(25)
    codes = on.shape.inside(on.transform.inverse_apply(points))
    if (codes == INSIDE).any():
        raise ConfigError(
            f"{where}: the rough layer on {what} ({layer.thickness * 1e3:.4g} um thick) runs "
            "into the solid itself (another part of the boolean covers or meets that face); "
            "choose a face the layer can lie on outside the solid"
        )
