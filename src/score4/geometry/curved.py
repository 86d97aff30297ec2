"""Rough layers on curved faces in Geant4 (:mod:`score4.world.curved`): a shell envelope and the
bent patch bodies placed around the axis.

The envelope is a ``G4Cons`` of the mother's material over the face's phi range, between the
z planes of the face's ends: the face's cone (or cylinder) and the same moved out by the layer
thickness along the face's normal (it touches the target's face and nothing of the target).
On a face of a boolean solid whose other parts cut or cover it, the envelope is one such G4Cons
segment per piece (:attr:`~score4.world.scene.CurvedRoughLayer.pieces`: the kept cells'
azimuth ranges and runs of rings; on a sphere G4Sphere segments), each cell placed in its
piece; a piece of a cone whose rings keep different azimuths ends on the rings' band cones
instead of z planes, a ``G4GenericPolycone`` segment of its meridian rectangle
(:func:`~score4.world.scene.normal_envelope`).
The rings keep clear of the envelope's ends (:meth:`score4.world.curved.RingLayout.make`). Each
variant bent onto a ring radius is one ``G4TessellatedSolid`` and one logical volume (all rings of a
cylinder share it), placed once per cell: turned about z to the cell's azimuth and moved along z to
its ring.

On a cylinder a spike grid's patch is instead a cell (a ``G4Tubs`` segment of the mother's
material) of bent G4Trds, one per spike layer and one per column of the slab
(:func:`place_bent_frustums`): the same body, tracked through analytic solids. On a cone the
bent layers are G4Traps and G4GenericTraps (:func:`bent_traps`) in a cell that is the common
part of two G4Cons (:func:`score4.world.curved.cone_cell`); a patch whose spike columns are
alike is one column cell placed across it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from score4.shapes import G4GenericPolycone as G4GenericPolyconeShape
from score4.shapes.faces import SphereFace
from score4.world.curved import cone_cell, sphere_cell
from score4.world.scene import CurvedRoughLayer, normal_envelope, wall_envelope

from ..surface.triangle_mesh import TriangleMesh
from .solids import tessellated_solid


def place_curved(g4, layer: CurvedRoughLayer, mother_lv, mother_material, material, placement):
    """Place the layer's envelope in ``mother_lv`` with ``placement`` (the target's transform
    in the mother, a :class:`~score4.shapes.Transform`) and its patches in it. Returns
    ``(patch logical volumes, objects to keep alive)``."""
    from .built import g4_solid
    from .tiling import _rotation, level_regions

    face = layer.ring_layout.face
    name = layer.name
    if isinstance(face, SphereFace):
        # a spherical shell over the zone, or one G4Sphere segment per piece of the envelope
        r = face.sphere_radius
        lo, hi = (r, r + layer.thickness) if face.sign > 0 else (r - layer.thickness, r)
        env_solids, zcs = [], []
        for n, view in enumerate(layer.envelope_views()):
            vf = view.ring_layout.face
            assert isinstance(vf, SphereFace)
            t0, t1 = vf.theta
            tag = name if n == 0 else f"{name}_env{n}"
            env_solids.append(g4.G4Sphere(tag, lo, hi, vf.phi0, vf.dphi, t0, t1 - t0))
            zcs.append(0.0)
    else:
        # one G4Cons per piece of the envelope (the face's whole shell, or the azimuth and
        # generator ranges holding the kept cells of a face a boolean's other parts cut)
        env_solids, zcs = [], []
        for n, view in enumerate(layer.envelope_views()):
            vf = view.ring_layout.face
            tag = name if n == 0 else f"{name}_env{n}"
            if view.normal_ends and not view.is_cylinder:  # ends on the rings' band cones
                rs, zs = normal_envelope(view)
                zc = 0.5 * (min(zs) + max(zs))
                contour = G4GenericPolyconeShape(vf.phi0, vf.dphi, rs, tuple(z - zc for z in zs))
                env_solids.append(g4_solid(g4, contour, tag))
                zcs.append(zc)
                continue
            rmin1, rmax1, rmin2, rmax2, dz, zc = wall_envelope(view)
            env_solids.append(g4.G4Cons(tag, rmin1, rmax1, rmin2, rmax2, dz, vf.phi0, vf.dphi))
            zcs.append(zc)
    rot = _rotation(g4, placement.rotation)
    keep: list = [rot]
    env_lvs = []
    for n, (env_solid, zc) in enumerate(zip(env_solids, zcs, strict=True)):
        tag = name if n == 0 else f"{name}_env{n}"
        env_lv = g4.G4LogicalVolume(env_solid, mother_material, tag)
        centre = placement.apply(np.array([0.0, 0.0, zc]))
        env_pv = g4.G4PVPlacement(
            g4.G4Transform3D(rot, g4.G4ThreeVector(*centre)),
            env_lv,
            tag,
            mother_lv,
            False,
            n,
            False,
        )
        keep.extend([env_solid, env_lv, env_pv])
        env_lvs.append(env_lv)
    env_lv, zc = env_lvs[0], zcs[0]
    lay = layer.ring_layout
    ring_key = [layer.ring_solid_key(j) for j in range(len(lay.v))]
    lvs: dict[tuple[int, float], object] = {}
    shifts: dict[tuple[int, float], float] = {}  # a cone's cell centre above its ring's
    patch_lvs: list = []
    cell_lvs: list = []  # the cells of bent frustums (mother material, ~2500 daughters each)
    column_lvs: list = []  # on a cone, a cell's column of spikes (placed across the cell)

    def cell_spikes(k: int, j: int, lv, tag: str, z_cell: float, column_solid):
        """Bent frustums of variant ``k`` in the cell ``lv`` of ring ``j``: when the spike
        grid's columns are alike, one column (``column_solid(angle)`` -> (solid, keep)) built
        once and placed ``nx`` times by rotation about z; else every spike in the cell."""
        grid = layer.variants[k].spikes
        assert grid is not None
        if not np.all(grid.heights == grid.heights[:, :1]):
            return place_bent_frustums(g4, layer, k, j, material, lv, tag, z_cell)
        angle = grid.width_x / float(lay.radius[j])
        col, col_keep = column_solid(angle)
        col_lv = g4.G4LogicalVolume(col, mother_material, f"{tag}_col")
        inner, inner_keep = place_bent_frustums(
            g4, layer, k, j, material, col_lv, f"{tag}_col", z_cell, column=True
        )
        xs = (np.arange(grid.nx) + 0.5) * grid.width_x - grid.size_x / 2
        for i, x in enumerate(xs):
            r3 = g4.G4RotationMatrix()
            r3.rotateZ(float(x) / float(lay.radius[j]))
            g4.G4PVPlacement(
                g4.G4Transform3D(r3, g4.G4ThreeVector()), col_lv, f"{tag}_col", lv, False, i, False
            )
        column_lvs.append(col_lv)
        keep.extend([*col_keep, col_lv])
        return inner, inner_keep

    def patch_lv(k: int, j: int):
        key = (k, ring_key[j])
        if key not in lvs:
            tag = f"{name}_v{k}_r{len(lvs)}"
            if layer.solid_kind(k) == "frustums" and layer.is_cylinder:
                py, step = lay.patch_size[1], float(lay.step[j])
                cell = g4.G4Tubs(tag, rmin1, rmax1, py / 2, -step / 2, step)
                lv = g4.G4LogicalVolume(cell, mother_material, tag)
                inner, inner_keep = place_bent_frustums(g4, layer, k, j, material, lv, tag)
                patch_lvs.extend(inner)
                cell_lvs.append(lv)
                keep.extend([cell, lv, *inner_keep])
            elif layer.solid_kind(k) == "frustums" and isinstance(face, SphereFace):
                # a G4Sphere segment about the sphere's centre (no shift in z)
                rlo, rhi, th0, dth, step = sphere_cell(lay, j, layer.thickness)
                cell = g4.G4Sphere(tag, rlo, rhi, -step / 2, step, th0, dth)
                lv = g4.G4LogicalVolume(cell, mother_material, tag)
                keep.extend([cell, lv])
                z_cell = -lay.ring_z(j)

                def sphere_column(angle: float):
                    col = g4.G4Sphere(f"{tag}_col", rlo, rhi, -angle / 2, angle, th0, dth)
                    return col, [col]

                inner, inner_keep = cell_spikes(k, j, lv, tag, z_cell, sphere_column)
                shifts[key] = z_cell
                patch_lvs.extend(inner)
                cell_lvs.append(lv)
                keep.extend(inner_keep)
            elif layer.solid_kind(k) == "frustums":  # a cone: the cell is two cones' common part
                a, b, z_cell = cone_cell(lay, j, layer.thickness)
                shell = g4.G4Cons(f"{tag}_a", *a)
                band = g4.G4Cons(f"{tag}_b", *b, 0.0, 2 * np.pi)
                cell = g4.G4IntersectionSolid(tag, shell, band)
                lv = g4.G4LogicalVolume(cell, mother_material, tag)
                keep.extend([shell, band, cell, lv])

                def cone_column(angle: float):
                    col_shell = g4.G4Cons(f"{tag}_ca", *a[:5], -angle / 2, angle)
                    col = g4.G4IntersectionSolid(f"{tag}_col", col_shell, band)
                    return col, [col_shell, col]

                inner, inner_keep = cell_spikes(k, j, lv, tag, z_cell, cone_column)
                shifts[key] = z_cell
                patch_lvs.extend(inner)
                cell_lvs.append(lv)
                keep.extend(inner_keep)
            else:
                bent = layer.bent(k, j)
                solid = tessellated_solid(g4, TriangleMesh(bent.vertices, bent.faces), tag)
                lv = g4.G4LogicalVolume(solid, material, tag)
                patch_lvs.append(lv)
                keep.extend([solid, lv])
            lvs[key] = lv
        return lvs[key]

    def place(lv, phi: float, z: float, mother, copy_no: int) -> None:
        r3 = g4.G4RotationMatrix()
        r3.rotateZ(phi)  # the object turned by phi about z
        g4.G4PVPlacement(
            g4.G4Transform3D(r3, g4.G4ThreeVector(0.0, 0.0, z)),
            lv,
            f"{name}_cell",
            mother,
            False,
            copy_no,
            False,
        )

    ring_z = [lay.ring_z(j) for j in range(len(lay.v))]
    cells = layer.cells()
    if isinstance(face, SphereFace) and any(
        layer.solid_kind(k) == "frustums" for k in range(len(layer.variants))
    ):
        # a sphere's cells of bent frustums: one band (a G4Sphere zone over the phi range of the
        # face, or of the envelope's piece) per ring and piece, its cells placed in it by rotation
        # about z (each ring's cell is one logical volume); the bands in the envelope's pieces
        rings_of: dict[tuple[int, int], list[tuple[int, float]]] = {}
        for j, _, k, phi in cells:
            rings_of.setdefault((j, layer.piece_of(j, phi)), []).append((k, phi))
        views = layer.envelope_views()
        for (j, n), row in sorted(rings_of.items()):
            rlo, rhi, th0, dth, _ = sphere_cell(lay, j, layer.thickness)
            tag = f"{name}_ring{j}" if n == 0 else f"{name}_ring{j}_{n}"
            vf = views[n].ring_layout.face
            band = g4.G4Sphere(tag, rlo, rhi, vf.phi0, vf.dphi, th0, dth)
            band_lv = g4.G4LogicalVolume(band, mother_material, tag)
            keep.extend([band, band_lv])
            for copy_no, (k, phi) in enumerate(row):
                lv = patch_lv(k, j)
                z_cell = shifts.get((k, ring_key[j]), 0.0)
                place(lv, phi, ring_z[j] + z_cell, band_lv, copy_no)
            place(band_lv, 0.0, 0.0, env_lvs[n], j)
        levels = [column_lvs, cell_lvs] if column_lvs else [cell_lvs]
        keep += level_regions(g4, levels, name)
        return patch_lvs, keep
    if isinstance(face, SphereFace) or abs(face.nrz[1]) > 1e-12:  # every patch in the envelope
        for copy_no, (j, _, k, phi) in enumerate(cells):
            lv = patch_lv(k, j)
            z_cell = shifts.get((k, ring_key[j]), 0.0)
            n = layer.piece_of(j, phi)
            place(lv, phi, ring_z[j] - zcs[n] + z_cell, env_lvs[n], copy_no)
        levels = [column_lvs, cell_lvs] if column_lvs else [cell_lvs]
        keep += level_regions(g4, levels, name) if cell_lvs else []
        return patch_lvs, keep
    # A cylinder: each ring is a shell of one row (a G4Tubs), and rings with the same variants in
    # the same order are one logical volume placed once per row: one ring of one variant serves
    # the whole wall.
    py = layer.patch_size[1]
    rings: dict[tuple, object] = {}
    by_row: dict[tuple[int, int], list[tuple[int, float]]] = {}  # (ring, piece) -> cells
    for j, _, k, phi in cells:
        by_row.setdefault((j, layer.piece_of(j, phi)), []).append((k, phi))
    views = layer.envelope_views()
    for (j, n), row in sorted(by_row.items()):
        # (the azimuths too: on a boolean's face rings may hold different cells)
        key = (ring_key[j], n, tuple((k, round(p, 12)) for k, p in row))
        if key not in rings:
            tag = f"{name}_ring{len(rings)}"
            vf = views[n].ring_layout.face
            ring_solid = g4.G4Tubs(tag, rmin1, rmax1, py / 2, vf.phi0, vf.dphi)
            ring_lv = g4.G4LogicalVolume(ring_solid, mother_material, tag)
            for copy_no, (k, phi) in enumerate(row):
                place(patch_lv(k, j), phi, 0.0, ring_lv, copy_no)
            rings[key] = ring_lv
            keep.extend([ring_solid, ring_lv])
        place(rings[key], 0.0, ring_z[j] - zcs[n], env_lvs[n], j)
    # The cells of frustums and the rings regions of their own: the walk down the volume tree
    # before each BeamOn (see level_regions) then visits each cell's ~2500 volumes once, not once
    # per cell of the wall.
    levels = [cell_lvs, list(rings.values())] if cell_lvs else []
    keep += level_regions(g4, levels, name)
    return patch_lvs, keep


def bent_corners(
    layer: CurvedRoughLayer, j: int, box: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Patch-local frustums (``box``: arrays ``x``, ``y`` (centre), ``z0``, ``z1`` (bottom and
    top height above the base plane), ``wxb``, ``wxt``, ``wyb``, ``wyt`` (full widths)) bent
    onto ring ``j`` as :meth:`RingLayout.bend` bends their corners, in the frame of a cell at
    phi = 0: the bottom and top corners (n, 4, 3), in the order (-x, -y), (+x, -y), (+x, +y),
    (-x, +y) of the patch-local corners."""
    lay = layer.ring_layout
    offset = layer.base_thickness + layer.lift
    n = len(box["x"])
    rows = []
    for z_key, wx_key, wy_key in (("z0", "wxb", "wyb"), ("z1", "wxt", "wyt")):
        pts = np.empty((n, 4, 3))
        for c, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
            pts[:, c, 0] = box["x"] + sx * box[wx_key] / 2
            pts[:, c, 1] = box["y"] + sy * box[wy_key] / 2
            pts[:, c, 2] = box[z_key]
        rows.append(lay.bend(pts.reshape(-1, 3), j, offset).reshape(n, 4, 3))
    return rows[0], rows[1]


def bent_trds(
    layer: CurvedRoughLayer, j: int, box: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frustums (``box``, see :func:`bent_corners`) bent onto ring ``j`` of a cylinder, in the
    frame of a cell at phi = 0.

    The four corners of a bent frustum's bottom (or top) lie at one distance from the axis and
    one azimuth pair symmetric about the frustum's centre azimuth, at one pair of z: a rectangle
    in a plane normal to the radius through the centre. Both rectangles are centred on that
    radius, so the bent frustum is exactly a G4Trd: returns its half sizes (n, 5: dx1, dx2, dy1,
    dy2, dz), centres (n, 3) and rotations (n, 3, 3; columns: the images of the Trd's x, y, z).
    """
    lay = layer.ring_layout
    n = len(box["x"])
    bottom, top = bent_corners(layer, j, box)
    phi = box["x"] / lay.radius[j]
    radial = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)])
    tangent = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros(n)])
    face = lay.face
    assert not isinstance(face, SphereFace)  # frustums are for cylinder walls and cones only
    up = np.sign(float(face.nrz[0])) * radial  # the Trd's +z: away from the base
    u0 = np.einsum("nc,nkc->nk", up, bottom).mean(axis=1)
    u1 = np.einsum("nc,nkc->nk", up, top).mean(axis=1)
    centre_bottom = bottom.mean(axis=1)
    centre_top = top.mean(axis=1)
    half = np.column_stack(
        [
            np.abs(np.einsum("nc,nkc->nk", tangent, bottom - centre_bottom[:, None])).max(axis=1),
            np.abs(np.einsum("nc,nkc->nk", tangent, top - centre_top[:, None])).max(axis=1),
            np.abs(bottom[:, :, 2] - centre_bottom[:, None, 2]).max(axis=1),
            np.abs(top[:, :, 2] - centre_top[:, None, 2]).max(axis=1),
            (u1 - u0) / 2,
        ]
    )
    centre = 0.5 * (centre_bottom + centre_top)
    y_axis = np.cross(up, tangent)
    rotation = np.stack([tangent, y_axis, up], axis=2)
    return half, centre, rotation


@dataclass
class BentTraps:
    """Frustums bent onto a cone as Geant4 solids (:func:`bent_traps`), in a cell's frame.

    ``apex``: True where the frustum ends in a point (a G4GenericTrap, ``generic``: its eight
    (x, y) vertices, four at -dz then four at +dz, clockwise); else a G4Trap with ``trap``:
    (dz, theta, phi, dy1, dx1, dx2, alpha1, dy2, dx3, dx4, alpha2). ``dz``: half heights;
    ``centre`` and ``rotation`` (columns: the solid's x, y, z axes) place each one;
    ``vertices`` (n, 8, 3): the solid's corners in the cell frame (G4Trap's order: -dz face
    (-y edge: -x, +x; +y edge: -x, +x), then the +dz face)."""

    apex: np.ndarray
    trap: np.ndarray
    generic: np.ndarray
    dz: np.ndarray
    centre: np.ndarray
    rotation: np.ndarray
    vertices: np.ndarray


def bent_traps(
    layer: CurvedRoughLayer, j: int, box: dict[str, np.ndarray], group: np.ndarray
) -> BentTraps:
    """Frustums (``box``, see :func:`bent_corners`) bent onto ring ``j`` of a cone, in the frame
    of a cell at phi = 0, as G4Traps (G4GenericTraps where a frustum ends in a point).

    The four bent corners of a frustum's bottom lie at two distances from the axis (the two
    generator positions), each pair symmetric about the frustum's azimuth: an isosceles
    trapezoid in a plane. Its top is another, in a plane tilted from the bottom's by
    ``t_r (cos a_top - cos a_bottom)`` (a: the half azimuth, ~1e-4 rad; ~1e-8 rad) and with
    edges that narrow along the generator at another rate than the bottom's (their side faces
    are not quite planar). Each frustum of one ``group`` (the layers of one spike, or one slab
    column) is made in the frame of the group's base (x: the tangent, z: the base plane's
    normal, away from the surface) with every face's corners projected onto a plane normal to z
    and every face's x half-widths narrowing along y at the base's rate: the side faces are
    planar, stacked layers share their faces exactly, and the corners move from the bent ones
    by at most ``t_r (a_bottom - a_top) dy`` (about 1e-7 mm for 10 um pyramids on a 20 mm
    radius; :attr:`BentTraps.vertices` against :func:`bent_corners` measures it). Slab columns
    have one azimuth pair at both faces and are exact but for rounding."""
    bottom, top = bent_corners(layer, j, box)
    n = len(bottom)
    first = np.unique(group, return_index=True)[1]
    base_of = np.searchsorted(group[first], group)
    base = bottom[first[base_of]]
    x_axis = base[:, 1] - base[:, 0] + base[:, 2] - base[:, 3]
    x_axis /= np.linalg.norm(x_axis, axis=1)[:, None]
    g = 0.5 * (base[:, 3] + base[:, 2] - base[:, 0] - base[:, 1])
    z_axis = np.cross(x_axis, g)
    z_axis /= np.linalg.norm(z_axis, axis=1)[:, None]
    up = top.mean(axis=1) - bottom.mean(axis=1)
    flip = np.einsum("nc,nc->n", z_axis, up) < 0
    z_axis[flip] *= -1
    y_axis = np.cross(z_axis, x_axis)
    rotation = np.stack([x_axis, y_axis, z_axis], axis=2)
    origin = base.mean(axis=1)

    def local(p: np.ndarray) -> np.ndarray:
        return np.einsum("nkc,nca->nka", p - origin[:, None], rotation)

    def face(p: np.ndarray) -> tuple[np.ndarray, ...]:
        """Centre x, centre y, half y extent, half x width at the centre, x half-width slope
        and z of a face's corners (n, 4, 3; local)."""
        ya, yb = p[:, [0, 1], 1].mean(axis=1), p[:, [3, 2], 1].mean(axis=1)
        ha, hb = (p[:, 1, 0] - p[:, 0, 0]) / 2, (p[:, 2, 0] - p[:, 3, 0]) / 2
        xc = (p[:, :, 0].sum(axis=1)) / 4
        yc, dy = (ya + yb) / 2, (yb - ya) / 2
        slope = np.divide(hb - ha, 2 * dy, out=np.zeros(n), where=np.abs(dy) > 0)
        return xc, yc, dy, (ha + hb) / 2, slope, p[:, :, 2].mean(axis=1)

    xb, yb, dyb, mb, slope_b, zb = face(local(bottom))
    xt, yt, dyt, mt, _, zt = face(local(top))
    slope = slope_b[first[base_of]]  # every face of a group narrows at its base's rate
    dz = (zt - zb) / 2
    apex = (box["wxt"] <= 0) & (box["wyt"] <= 0)
    # the solids' corners (local): -dz face then +dz face; -y edge (-x, +x), +y edge (-x, +x)
    verts = np.empty((n, 8, 3))
    for f, (xc, yc, dy, m, z) in enumerate(((xb, yb, dyb, mb, zb), (xt, yt, dyt, mt, zt))):
        for e, sy in enumerate((-1.0, 1.0)):
            half = m + sy * slope * dy
            for c, sx in enumerate((-1.0, 1.0)):
                verts[:, 4 * f + 2 * e + c] = np.column_stack([xc + sx * half, yc + sy * dy, z])
    mid = np.column_stack([(xb + xt) / 2, (yb + yt) / 2, (zb + zt) / 2])
    tx, ty = (xt - xb) / (2 * dz), (yt - yb) / (2 * dz)
    theta = np.arctan(np.hypot(tx, ty))
    phi = np.arctan2(ty, tx)
    ady, ady_t = np.abs(dyb), np.abs(dyt)
    # dx at -y and +y of each face (a face whose y runs the other way swaps them)
    lo_b = np.where(dyb >= 0, mb - slope * dyb, mb + slope * dyb)
    hi_b = np.where(dyb >= 0, mb + slope * dyb, mb - slope * dyb)
    lo_t = np.where(dyt >= 0, mt - slope * dyt, mt + slope * dyt)
    hi_t = np.where(dyt >= 0, mt + slope * dyt, mt - slope * dyt)
    zeros = np.zeros(n)
    trap = np.column_stack([dz, theta, phi, ady, lo_b, hi_b, zeros, ady_t, lo_t, hi_t, zeros])
    # G4GenericTrap: its frame is the local frame moved to the middle height, clockwise seen
    # from +z: (-x, -y), (-x, +y), (+x, +y), (+x, -y) of each face
    order = [0, 2, 3, 1, 4, 6, 7, 5]
    centre_local = np.where(apex[:, None], np.column_stack([zeros, zeros, mid[:, 2]]), mid)
    generic = verts[:, order, :2]
    cell_verts = np.einsum("nca,nka->nkc", rotation, verts) + origin[:, None]
    centre = np.einsum("nca,na->nc", rotation, centre_local) + origin
    return BentTraps(apex, trap, generic, dz, centre, rotation, cell_verts)


def place_bent_frustums(
    g4,
    layer: CurvedRoughLayer,
    k: int,
    j: int,
    material,
    cell_lv,
    name: str,
    z_shift: float = 0.0,
    column: bool = False,
) -> tuple[list, list]:
    """Place variant ``k`` (a spike grid) bent onto ring ``j`` in ``cell_lv`` (the patch's cell
    at phi = 0, its centre ``z_shift`` above the ring's): one solid per column of cells for the
    slab (its floor and top are the chords the tessellated body has) and one per spike layer;
    on a cylinder G4Trds (:func:`bent_trds`), on a cone G4Traps and, for layers that end in a
    point, G4GenericTraps (:func:`bent_traps`). Shapes repeat, so solids and logical volumes are
    shared. ``column``: only the first column of spikes (and its column of the slab), moved to
    the cell's centre azimuth (a cell of one column, placed across the patch when all columns
    are alike). Returns ``(logical volumes of material, objects to keep alive)``."""
    from .tiling import _rotation

    grid = layer.variants[k].spikes
    assert grid is not None
    f = grid.frustums()
    py = layer.patch_size[1]
    base = layer.base_thickness
    edges = np.arange(grid.nx + 1) * grid.width_x - grid.size_x / 2
    columns = {
        "x": 0.5 * (edges[1:] + edges[:-1]),
        "y": np.zeros(grid.nx),
        "z0": np.full(grid.nx, -base),
        "z1": np.zeros(grid.nx),
        "wxb": np.diff(edges),
        "wxt": np.diff(edges),
        "wyb": np.full(grid.nx, py),
        "wyt": np.full(grid.nx, py),
    }
    spikes = {
        "x": f["x"],
        "y": f["y"],
        "z0": f["z"] - f["height"] / 2,
        "z1": f["z"] + f["height"] / 2,
        "wxb": f["width_x_bottom"],
        "wxt": f["width_x_top"],
        "wyb": f["width_y_bottom"],
        "wyt": f["width_y_top"],
    }
    if column:  # the first column at x = 0
        first = np.asarray(f["spike"]) % grid.nx == 0
        spikes = {key: value[first] for key, value in spikes.items()}
        spikes["x"] = np.zeros(int(first.sum()))
        columns = {key: value[:1] for key, value in columns.items()}
        columns["x"] = np.zeros(1)
        f = f[first]
    spike_of = np.asarray(f["spike"], np.int64)
    parts = [("c", columns, np.arange(len(columns["x"]))), ("s", spikes, spike_of)]
    if isinstance(layer.ring_layout.face, SphereFace):
        # a column of the slab would be one trap the patch's length long, its floor a chord
        # py^2 / 8R inside the sphere: the slab is cut per spike instead, each block the first
        # layer of its spike (its floor the body's floor of that cell, flat_body)
        ids = np.unique(spike_of)
        ix, iy = ids % grid.nx, ids // grid.nx
        slab = {
            "x": spikes["x"][np.searchsorted(spike_of, ids)] if column else grid.x_centres[ix],
            "y": grid.y_centres[iy],
            "z0": np.full(len(ids), -base),
            "z1": np.zeros(len(ids)),
            "wxb": np.full(len(ids), grid.width_x),
            "wxt": np.full(len(ids), grid.width_x),
            "wyb": np.full(len(ids), grid.width_y),
            "wyt": np.full(len(ids), grid.width_y),
        }
        merged = {key: np.concatenate([slab[key], spikes[key]]) for key in slab}
        group = np.concatenate([ids, spike_of])
        order = np.lexsort((np.arange(len(group)), group))  # per spike: its block, its layers
        parts = [("s", {key: value[order] for key, value in merged.items()}, group[order])]
    lvs: list = []
    keep: list = []
    shapes: dict[tuple, object] = {}
    copy_no = 0
    shift = np.array([0.0, 0.0, z_shift])
    for part, box, group in parts:
        solids: list[tuple[tuple, tuple]] = []  # (sharing key, (kind, parameters))
        if layer.is_cylinder:
            half, centre, rotation = bent_trds(layer, j, box)
            solids += [(("trd", *np.round(h, 15).tolist()), ("trd", h.tolist())) for h in half]
        else:
            traps = bent_traps(layer, j, box, group)
            centre, rotation = traps.centre, traps.rotation
            for n in range(len(centre)):
                if traps.apex[n]:
                    dz, xy = float(traps.dz[n]), traps.generic[n]
                    key = ("gen", float(np.round(dz, 12)), *np.round(xy, 12).ravel().tolist())
                    solids.append((key, ("gen", (dz, xy.tolist()))))
                else:
                    p = traps.trap[n]
                    solids.append((("trap", *np.round(p, 12).tolist()), ("trap", p.tolist())))
        for n, (key, (kind, args)) in enumerate(solids):
            lv = shapes.get(key)
            if lv is None:
                tag = f"{name}_{part}{len(shapes)}"
                solid = _make_solid(g4, tag, kind, args)
                lv = g4.G4LogicalVolume(solid, material, tag)
                shapes[key] = lv
                lvs.append(lv)
                keep += [solid, lv]
            rot = _rotation(g4, rotation[n])
            g4.G4PVPlacement(
                g4.G4Transform3D(rot, g4.G4ThreeVector(*(centre[n] - shift).tolist())),
                lv,
                f"{name}_{part}",
                cell_lv,
                False,
                copy_no,
                False,
            )
            copy_no += 1
    return lvs, keep


def _make_solid(g4, tag: str, kind: str, args):
    """A G4Trd (``args``: its five half sizes), G4Trap (its eleven parameters) or
    G4GenericTrap (``(dz, eight (x, y) vertices)``)."""
    if kind == "trd":
        return g4.G4Trd(tag, *args)
    if kind == "trap":
        return g4.G4Trap(tag, *args)
    dz, xy = args
    vertices = g4.G4TwoVectorVector()
    for x, y in xy:
        vertices.append(g4.G4TwoVector(x, y))
    return g4.G4GenericTrap(tag, dz, vertices)
