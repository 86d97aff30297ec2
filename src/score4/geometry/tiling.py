"""Rough layers in Geant4: patch solids and their native tiling over a face.

Native tiling: the layer is an envelope box of the world material on the face (face size x
layer thickness, outside the target); every cell of the patch map is a ``G4PVPlacement`` of its
variant's cell box (one per variant, shared by all its cells, holding the variant's patch), so
navigation stays in C++.
The envelope is rotated into the face frame of :mod:`score4.scene`; inside it the patch bodies
have their slab bottom on the face.
"""

from __future__ import annotations

import numpy as np

from ..scene import RoughLayer
from .blocks import place_blocks
from .solids import multiunion_solid, tessellated_solid


def _rotation(g4, r: np.ndarray):
    rot = g4.G4RotationMatrix()
    v = g4.G4ThreeVector
    rot.rotateAxes(v(*r[:, 0]), v(*r[:, 1]), v(*r[:, 2]))  # columns: images of x, y, z
    return rot


def place_variant(
    g4,
    layer: RoughLayer,
    k: int,
    mother_lv,
    z: float,
    material,
    name: str,
    copy_no: int = 0,
    copies: int = 1,
) -> tuple[list, list]:
    """Place patch variant ``k`` in ``mother_lv`` with its base plane at height ``z``.

    The patch is one solid (``tessellated`` / ``multiunion``: the closed body, slab below the
    base plane) or a grid of closed blocks (``blocks``, :mod:`.blocks`).
    ``copies`` is how many times ``mother_lv`` is placed (blocks: bounds the placed blocks).
    Returns ``(logical volumes of the patch's material, objects to keep alive)``.
    """
    surface = layer.variants[k]
    kind = layer.solid_kind(k)
    if kind == "blocks":
        return place_blocks(
            g4,
            surface,
            layer.base_thickness,
            layer.config.block_cells,
            material,
            mother_lv,
            z,
            name,
            copies,
        )
    if kind == "multiunion":
        solid, parts = multiunion_solid(g4, surface.spikes, layer.base_thickness, name)
    else:
        solid, parts = tessellated_solid(g4, surface.body(layer.base_thickness), name), []
    lv = g4.G4LogicalVolume(solid, material, name)
    pv = g4.G4PVPlacement(
        None, g4.G4ThreeVector(0, 0, z), lv, name, mother_lv, False, copy_no, False
    )
    return [lv], [solid, parts, lv, pv]


def place_native(g4, layer: RoughLayer, mother_lv, world_material, material) -> tuple[list, list]:
    """Place the layer's envelope in ``mother_lv`` and the patches in it.

    Returns ``(patch logical volumes, objects to keep alive)``.
    """
    lu, lv = layer.frame.size
    t = layer.thickness
    name = layer.name
    env_solid = g4.G4Box(name, lu / 2, lv / 2, t / 2)
    env_lv = g4.G4LogicalVolume(env_solid, world_material, name)
    rot = _rotation(g4, layer.frame.rotation)
    centre = layer.frame.to_world(np.array([0.0, 0.0, t / 2]))
    env_pv = g4.G4PVPlacement(
        g4.G4Transform3D(rot, g4.G4ThreeVector(*centre)), env_lv, name, mother_lv, False, 0, False
    )
    keep = [env_solid, env_lv, rot, env_pv]
    # Each variant's patch sits in a vacuum cell box; the cell boxes are what the envelope holds.
    # Geant4 sizes every daughter when it voxelises the envelope: 40 000 multi-union patches
    # took ~1 min per process (bench_tiling.py), 40 000 boxes take milliseconds.
    px, py = layer.patch_size
    z = -t / 2 + layer.base_thickness  # base plane of the patches in cell-box coordinates
    patch_lvs, cell_lvs = [], []
    for k in range(len(layer.variants)):
        cell_solid = g4.G4Box(f"{name}_cell{k}", px / 2, py / 2, t / 2)
        cell_lv = g4.G4LogicalVolume(cell_solid, world_material, f"{name}_cell{k}")
        copies = int((layer.patch_map.variants == k).sum())
        lvs_k, keep_k = place_variant(
            g4, layer, k, cell_lv, z, material, f"{name}_v{k}", copies=copies
        )
        keep += [cell_solid, cell_lv, keep_k]
        patch_lvs += lvs_k
        cell_lvs.append(cell_lv)
    variants = layer.patch_map.variants
    ny, nx = variants.shape
    if layer.config.native_layout == "replicas":
        # rows of cells along y in the envelope, cells along x in each row: two replica levels
        row_solid = g4.G4Box(f"{name}_row", lu / 2, py / 2, t / 2)
        row_lv = g4.G4LogicalVolume(row_solid, world_material, f"{name}_row")
        rows = g4.G4PVReplica(f"{name}_row", row_lv, env_lv, g4.EAxis.kYAxis, ny, py, 0.0)
        cells = g4.G4PVReplica(f"{name}_cell", cell_lvs[0], row_lv, g4.EAxis.kXAxis, nx, px, 0.0)
        keep += [row_solid, row_lv, rows, cells]
        return patch_lvs, keep
    centres = layer.cell_centres()
    for j in range(ny):
        for i in range(nx):
            where = g4.G4ThreeVector(float(centres[j, i, 0]), float(centres[j, i, 1]), 0.0)
            pv = g4.G4PVPlacement(
                None,
                where,
                cell_lvs[variants[j, i]],
                f"{name}_cell",
                env_lv,
                False,
                i * ny + j,
                False,
            )
            keep.append(pv)
    return patch_lvs, keep
