"""Rough layers on curved faces in Geant4 (:mod:`score4.world.curved`): a shell envelope and the
bent patch bodies placed around the axis.

The envelope is a ``G4Cons`` of the mother's material over the face's phi range, between the
z planes of the face's ends: the face's cone (or cylinder) and the same moved out by the layer
thickness along the face's normal (it touches the target's face and nothing of the target).
The rings keep clear of the envelope's ends (:meth:`score4.world.curved.RingLayout.make`). Each
variant bent onto a ring radius is one ``G4TessellatedSolid`` and one logical volume (all rings of a
cylinder share it), placed once per cell: turned about z to the cell's azimuth and moved along z to
its ring.
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
    from .tiling import _rotation

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
    lvs: dict[tuple[int, float], object] = {}
    patch_lvs: list = []

    def patch_lv(k: int, j: int):
        key = (k, layer.ring_solid_key(j))
        if key not in lvs:
            bent = layer.bent(k, j)
            tag = f"{name}_v{k}_r{len(lvs)}"
            solid = tessellated_solid(g4, TriangleMesh(bent.vertices, bent.faces), tag)
            lv = g4.G4LogicalVolume(solid, material, tag)
            lvs[key] = lv
            patch_lvs.append(lv)
            keep.extend([solid, lv])
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

    lay = layer.ring_layout
    ring_z = [lay.ring_z(j) for j in range(len(lay.v))]
    cells = layer.cells()
    if isinstance(face, SphereFace) or abs(face.nrz[1]) > 1e-12:  # every patch in the envelope
        for copy_no, (j, _, k, phi) in enumerate(cells):
            place(patch_lv(k, j), phi, ring_z[j] - zc, env_lv, copy_no)
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
        key = (layer.ring_solid_key(j), tuple(k for k, _ in row))
        if key not in rings:
            tag = f"{name}_ring{len(rings)}"
            ring_solid = g4.G4Tubs(tag, rmin1, rmax1, py / 2, face.phi0, face.dphi)
            ring_lv = g4.G4LogicalVolume(ring_solid, mother_material, tag)
            for copy_no, (k, phi) in enumerate(row):
                place(patch_lv(k, j), phi, 0.0, ring_lv, copy_no)
            rings[key] = ring_lv
            keep.extend([ring_solid, ring_lv])
        place(rings[key], 0.0, ring_z[j] - zc, env_lv, j)
    return patch_lvs, keep
