"""Rough layers on curved faces in Geant4 (:mod:`score4.world.curved`): a shell envelope and the
bent patch bodies placed around the axis.

The envelope is a ``G4Cons`` of the mother's material over the face's phi range, between the
z planes of the face's ends: the face's cone (or cylinder) and the same moved out by the layer
thickness along the face's normal (it touches the target's face and nothing of the target).
The rings keep clear of the envelope's ends (:meth:`score4.world.curved.RingLayout.make`). Each
variant bent onto a ring radius is one ``G4TessellatedSolid`` and one logical volume (all rings of a
cylinder share it), placed once per cell: turned about z to the cell's azimuth and moved along z to
its ring.

On a cylinder a spike grid's patch is instead a cell (a ``G4Tubs`` segment of the mother's
material) of bent G4Trds, one per spike layer and one per column of the slab
(:func:`place_bent_frustums`): the same body, tracked through analytic solids.
"""

from __future__ import annotations

import numpy as np

from score4.shapes.faces import SphereFace
from score4.world.scene import CurvedRoughLayer

from ..surface.triangle_mesh import TriangleMesh
from .solids import tessellated_solid


def envelope_cone(layer: CurvedRoughLayer) -> tuple[float, float, float, float, float, float]:
    """``(rmin1, rmax1, rmin2, rmax2, dz, z_centre)`` of the envelope: the face's cone (or
    cylinder) and the same moved out by the layer thickness along the face normal, between the
    z planes of the face's ends."""
    face = layer.ring_layout.face
    assert not isinstance(face, SphereFace)
    (r1, z1), (r2, z2) = face.rz1, face.rz2
    if z1 > z2:
        (r1, z1), (r2, z2) = (r2, z2), (r1, z1)
    tz = abs(face._tangent[1])
    shift = np.sign(face.nrz[0]) * layer.thickness / tz  # the offset surface, at the same z
    a1, b1 = sorted((r1, r1 + shift))
    a2, b2 = sorted((r2, r2 + shift))
    return float(a1), float(b1), float(a2), float(b2), 0.5 * (z2 - z1), 0.5 * (z1 + z2)


def place_curved(g4, layer: CurvedRoughLayer, mother_lv, mother_material, material, placement):
    """Place the layer's envelope in ``mother_lv`` with ``placement`` (the target's transform
    in the mother, a :class:`~score4.shapes.Transform`) and its patches in it. Returns
    ``(patch logical volumes, objects to keep alive)``."""
    from .tiling import _rotation, level_regions

    face = layer.ring_layout.face
    name = layer.name
    if isinstance(face, SphereFace):  # a spherical shell over the zone
        r = face.sphere_radius
        lo, hi = (r, r + layer.thickness) if face.sign > 0 else (r - layer.thickness, r)
        t0, t1 = face.theta
        env_solid = g4.G4Sphere(name, lo, hi, face.phi0, face.dphi, t0, t1 - t0)
        zc = 0.0
    else:
        rmin1, rmax1, rmin2, rmax2, dz, zc = envelope_cone(layer)
        env_solid = g4.G4Cons(name, rmin1, rmax1, rmin2, rmax2, dz, face.phi0, face.dphi)
    env_lv = g4.G4LogicalVolume(env_solid, mother_material, name)
    rot = _rotation(g4, placement.rotation)
    centre = placement.apply(np.array([0.0, 0.0, zc]))
    env_pv = g4.G4PVPlacement(
        g4.G4Transform3D(rot, g4.G4ThreeVector(*centre)),
        env_lv,
        name,
        mother_lv,
        False,
        0,
        False,
    )
    keep: list = [env_solid, env_lv, rot, env_pv]
    lay = layer.ring_layout
    lvs: dict[tuple[int, float], object] = {}
    patch_lvs: list = []
    cell_lvs: list = []  # the cells of bent frustums (mother material, ~2500 daughters each)

    def patch_lv(k: int, j: int):
        key = (k, layer.ring_solid_key(j))
        if key not in lvs:
            tag = f"{name}_v{k}_r{len(lvs)}"
            if layer.solid_kind(k) == "frustums":
                py, step = lay.patch_size[1], float(lay.step[j])
                cell = g4.G4Tubs(tag, rmin1, rmax1, py / 2, -step / 2, step)
                lv = g4.G4LogicalVolume(cell, mother_material, tag)
                inner, inner_keep = place_bent_frustums(g4, layer, k, j, material, lv, tag)
                patch_lvs.extend(inner)
                cell_lvs.append(lv)
                keep.extend([cell, lv, *inner_keep])
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
    if isinstance(face, SphereFace) or abs(face.nrz[1]) > 1e-12:  # every patch in the envelope
        for copy_no, (j, _, k, phi) in enumerate(cells):
            place(patch_lv(k, j), phi, ring_z[j] - zc, env_lv, copy_no)
        keep += level_regions(g4, [cell_lvs], name) if cell_lvs else []
        return patch_lvs, keep
    # A cylinder: each ring is a shell of one row (a G4Tubs), and rings with the same variants in
    # the same order are one logical volume placed once per row: one ring of one variant serves
    # the whole wall.
    py = layer.patch_size[1]
    rings: dict[tuple, object] = {}
    by_row: dict[int, list[tuple[int, float]]] = {}
    for j, _, k, phi in cells:
        by_row.setdefault(j, []).append((k, phi))
    for j, row in sorted(by_row.items()):
        # (the azimuths too: on a boolean's face rings may hold different cells)
        key = (layer.ring_solid_key(j), tuple((k, round(p, 12)) for k, p in row))
        if key not in rings:
            tag = f"{name}_ring{len(rings)}"
            ring_solid = g4.G4Tubs(tag, rmin1, rmax1, py / 2, face.phi0, face.dphi)
            ring_lv = g4.G4LogicalVolume(ring_solid, mother_material, tag)
            for copy_no, (k, phi) in enumerate(row):
                place(patch_lv(k, j), phi, 0.0, ring_lv, copy_no)
            rings[key] = ring_lv
            keep.extend([ring_solid, ring_lv])
        place(rings[key], 0.0, ring_z[j] - zc, env_lv, j)
    # The cells of frustums and the rings regions of their own: the walk down the volume tree
    # before each BeamOn (see level_regions) then visits each cell's ~2500 volumes once, not once
    # per cell of the wall.
    levels = [cell_lvs, list(rings.values())] if cell_lvs else []
    keep += level_regions(g4, levels, name)
    return patch_lvs, keep


def bent_trds(
    layer: CurvedRoughLayer, j: int, box: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Patch-local frustums (``box``: arrays ``x``, ``y`` (centre), ``z0``, ``z1`` (bottom and
    top height above the base plane), ``wxb``, ``wxt``, ``wyb``, ``wyt`` (full widths)) bent
    onto ring ``j`` of a cylinder as :meth:`RingLayout.bend` bends their corners, in the frame of
    a cell at phi = 0.

    The four corners of a bent frustum's bottom (or top) lie at one distance from the axis and
    one azimuth pair symmetric about the frustum's centre azimuth, at one pair of z: a rectangle
    in a plane normal to the radius through the centre. Both rectangles are centred on that
    radius, so the bent frustum is exactly a G4Trd: returns its half sizes (n, 5: dx1, dx2, dy1,
    dy2, dz), centres (n, 3) and rotations (n, 3, 3; columns: the images of the Trd's x, y, z).
    """
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
    bottom, top = rows
    phi = box["x"] / lay.radius[j]
    radial = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)])
    tangent = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros(n)])
    face = lay.face
    assert not isinstance(face, SphereFace)  # frustums are for cylinder walls only
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


def place_bent_frustums(
    g4, layer: CurvedRoughLayer, k: int, j: int, material, cell_lv, name: str
) -> tuple[list, list]:
    """Place variant ``k`` (a spike grid) bent onto ring ``j`` of a cylinder in ``cell_lv`` (the
    patch's cell, a G4Tubs segment at phi = 0): one G4Trd per column of cells for the slab (its
    floor and top are the chords the tessellated body has) and one per spike layer
    (:func:`bent_trds`). Shapes repeat, so G4Trds and logical volumes are shared. Returns
    ``(logical volumes of material, objects to keep alive)``."""
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
    lvs: list = []
    keep: list = []
    shapes: dict[tuple, object] = {}
    copy_no = 0
    for part, box in (("c", columns), ("s", spikes)):
        half, centre, rotation = bent_trds(layer, j, box)
        keys = [tuple(h) for h in np.round(half, 15).tolist()]
        for n, key in enumerate(keys):
            lv = shapes.get(key)
            if lv is None:
                tag = f"{name}_{part}{len(shapes)}"
                trd = g4.G4Trd(tag, *half[n].tolist())
                lv = g4.G4LogicalVolume(trd, material, tag)
                shapes[key] = lv
                lvs.append(lv)
                keep += [trd, lv]
            rot = _rotation(g4, rotation[n])
            g4.G4PVPlacement(
                g4.G4Transform3D(rot, g4.G4ThreeVector(*centre[n].tolist())),
                lv,
                f"{name}_{part}",
                cell_lv,
                False,
                copy_no,
                False,
            )
            copy_no += 1
    return lvs, keep
