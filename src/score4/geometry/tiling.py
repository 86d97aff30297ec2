"""Rough layers in Geant4: patch solids and their native tiling over a face.

Native tiling: the layer is an envelope box of the world material on the face (face size x
layer thickness, outside the target); every cell of the patch map is a placement of its
variant's cell box (one per variant, shared by all its cells, holding the variant's patch), so
navigation stays in C++. Layouts (``native_layout``):

* ``placements``: one ``G4PVPlacement`` per cell, all in the envelope (the reference layout);
* ``replicas``: two levels of ``G4PVReplica`` (rows of cells; one variant only);
* ``auto`` (the default): a grid of more than :data:`MAX_DAUGHTERS` cells is grouped 2 x 2
  into group boxes, level after level, until the envelope holds at most :data:`MAX_DAUGHTERS`
  boxes (:func:`place_nested`); ``nested`` groups until it holds at most 4, at any grid size. Groups with the same content share one
  logical volume, so a face of one variant needs a few dozen placements at any size, and a
  random map of several variants about a third of its cell count. No mother holds millions of
  daughters (a flat list of 4 million placements took 2.6 GB and 20 s to build). A grid of at most
  :data:`MAX_DAUGHTERS` cells is placed exactly as ``placements`` does.
The envelope is rotated into the face frame of :mod:`score4.scene`; inside it the patch bodies
have their slab bottom on the face.
"""

from __future__ import annotations

import numpy as np

from ..scene import RoughLayer
from .solids import multiunion_solid, tessellated_solid

#: Nested layout: most boxes one mother (the envelope) holds directly (50 x 50).
MAX_DAUGHTERS = 2500


def _rotation(g4, r: np.ndarray):
    rot = g4.G4RotationMatrix()
    v = g4.G4ThreeVector
    rot.rotateAxes(v(*r[:, 0]), v(*r[:, 1]), v(*r[:, 2]))  # columns: images of x, y, z
    return rot


def variant_solid(g4, layer: RoughLayer, k: int, name: str):
    """(solid, keep) of patch variant ``k``: the closed body, base plane at z = 0, slab below."""
    surface = layer.variants[k]
    if layer.solid_kind(k) == "multiunion":
        return multiunion_solid(g4, surface.spikes, layer.base_thickness, name)
    solid = tessellated_solid(g4, surface.body(layer.base_thickness), name)
    return solid, []


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
        solid, parts = variant_solid(g4, layer, k, f"{name}_v{k}")
        lv_k = g4.G4LogicalVolume(solid, material, f"{name}_v{k}")
        cell_solid = g4.G4Box(f"{name}_cell{k}", px / 2, py / 2, t / 2)
        cell_lv = g4.G4LogicalVolume(cell_solid, world_material, f"{name}_cell{k}")
        patch_pv = g4.G4PVPlacement(
            None, g4.G4ThreeVector(0, 0, z), lv_k, f"{name}_v{k}", cell_lv, False, 0, False
        )
        keep += [solid, parts, lv_k, cell_solid, cell_lv, patch_pv]
        patch_lvs.append(lv_k)
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
    layout = layer.config.native_layout
    if layout == "nested" or (layout == "auto" and variants.size > MAX_DAUGHTERS):
        most = MAX_DAUGHTERS if layout == "auto" else 4  # nested: group all the way (tests)
        keep += place_nested(
            g4, variants, cell_lvs, (px, py, t), env_lv, world_material, name, most
        )
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


def group_grid(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group a grid of box ids 2 x 2: ``(patterns, grid)``.

    ``ids[j, i]`` (row ``j`` along y) holds non-negative box ids. ``patterns[m]`` is the
    ``(2, 2)`` block of child ids of group ``m`` (``[dj, di]``; -1 where a group on the far edge
    of an odd-sized grid has no child), one row per distinct block; ``grid[J, I]`` is the
    pattern of the group holding cells ``[2J:2J+2, 2I:2I+2]``.
    """
    ny, nx = ids.shape
    padded = np.full((ny + ny % 2, nx + nx % 2), -1, dtype=np.int64)
    padded[:ny, :nx] = ids
    gy, gx = padded.shape[0] // 2, padded.shape[1] // 2
    blocks = padded.reshape(gy, 2, gx, 2).transpose(0, 2, 1, 3).reshape(gy * gx, 4)
    _, first, inverse = np.unique(blocks, axis=0, return_index=True, return_inverse=True)
    return blocks[first].reshape(-1, 2, 2), inverse.reshape(gy, gx)


def place_nested(
    g4,
    variants: np.ndarray,
    cell_lvs: list,
    cell: tuple,
    env_lv,
    world_material,
    name: str,
    max_daughters: int = MAX_DAUGHTERS,
) -> list:
    """Place the cells of ``variants`` in ``env_lv`` as nested 2 x 2 groups (see the module doc).

    ``cell`` is ``(px, py, t)``, the cell box size. While the grid has more than
    ``max_daughters`` boxes, the next level groups the boxes of the level below
    2 x 2 (edge groups of an odd grid are 1 x 2, 2 x 1 or 1 x 1), one logical volume per distinct
    group; the envelope holds the last level. Returns the Geant4 solids and logical volumes to
    keep alive; the placements themselves belong to Geant4 (their mothers) and no Python object
    is kept per placement.
    """
    px, py, t = cell
    vec = g4.G4ThreeVector
    lvs = list(cell_lvs)
    span_x = [1] * len(lvs)  # cells covered by box id, along x and y
    span_y = [1] * len(lvs)
    ids = np.asarray(variants, dtype=np.int64)
    keep: list = []
    level = 0
    while ids.size > max_daughters:
        level += 1
        patterns, grid = group_grid(ids)
        first_id = len(lvs)
        for m, block in enumerate(patterns.tolist()):
            # block[dj][di]; the columns' widths and the rows' heights, in cells
            widths = [span_x[block[0][di]] if block[0][di] >= 0 else 0 for di in (0, 1)]
            heights = [span_y[block[dj][0]] if block[dj][0] >= 0 else 0 for dj in (0, 1)]
            w, h = sum(widths), sum(heights)
            tag = f"{name}_g{level}_{m}"
            solid = g4.G4Box(tag, w * px / 2, h * py / 2, t / 2)
            lv = g4.G4LogicalVolume(solid, world_material, tag)
            for dj in (0, 1):
                for di in (0, 1):
                    child = block[dj][di]
                    if child < 0:
                        continue
                    x = (-w / 2 + di * widths[0] + widths[di] / 2) * px
                    y = (-h / 2 + dj * heights[0] + heights[dj] / 2) * py
                    g4.G4PVPlacement(
                        None, vec(x, y, 0.0), lvs[child], tag, lv, False, 2 * dj + di, False
                    )
            keep += [solid, lv]
            lvs.append(lv)
            span_x.append(w)
            span_y.append(h)
        ids = grid + first_id
    # the envelope holds the last level: box (I, J) starts at cell (I * 2**level, J * 2**level)
    ny, nx = ids.shape
    size = 2**level
    lu, lv_ = sum(span_x[k] for k in ids[0]) * px, sum(span_y[k] for k in ids[:, 0]) * py
    for j in range(ny):
        for i in range(nx):
            k = int(ids[j, i])
            x = -lu / 2 + (i * size + span_x[k] / 2) * px
            y = -lv_ / 2 + (j * size + span_y[k] / 2) * py
            g4.G4PVPlacement(
                None, vec(x, y, 0.0), lvs[k], f"{name}_g{level}", env_lv, False, j * nx + i, False
            )
    return keep
