"""Rough layers in Geant4: patch solids and their native tiling over a face.

Native tiling: the layer is an envelope box of the world material on the face (face size x
layer thickness, outside the target); every cell of the patch map is a placement of its
variant's cell box (one per variant, shared by all its cells, holding the variant's patch), so
navigation stays in C++. Layouts (``native_layout``):

* ``placements``: one ``G4PVPlacement`` per cell, all in the envelope (the reference layout);
* ``replicas``: two levels of ``G4PVReplica`` (rows of cells; one variant only);
* ``auto`` (the default): up to :data:`MAX_DAUGHTERS` cells as ``placements``; a larger grid
  in nested groups of cells (:func:`place_nested`): one level of ``g`` x ``g`` groups when that
  needs at most :data:`PLACEMENT_BUDGET` placements (always for a face of one variant), else
  2 x 2 groups first, level by level (:func:`grouping_plan`). Groups with the same content share
  one logical volume, so a face of one variant needs a few thousand placements at any size, and
  no mother holds more than :data:`MAX_DAUGHTERS` daughters (a flat list of 4 million
  placements took 2.6 GB and 20 s to build; a Python object per placement is not kept);
* ``nested``: the same at any grid size, down to at most 4 boxes in the envelope (deep trees:
  for tests and comparisons).

The envelope is rotated into the face frame of :mod:`score4.world.scene`; inside it the patch bodies
have their slab bottom on the face.
"""

from __future__ import annotations

import numpy as np

from score4.world.scene import FaceFrame, RoughLayer

from ..surface.patchmap import MAX_TOP_BOXES
from .block_solids import place_blocks
from .frustums import place_frustums
from .solids import multiunion_solid, tessellated_solid

#: Nested layout: most boxes one mother (the envelope) holds directly (50 x 50); fill: tiles
#: makes its tiles of the group size this implies (score4.surface.patchmap.tile_cells).
MAX_DAUGHTERS = MAX_TOP_BOXES
#: Nested layout: most placements one level of large groups may take (see grouping_plan).
PLACEMENT_BUDGET = 300_000


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
) -> tuple[list, list]:
    """Place patch variant ``k`` in ``mother_lv`` with its base plane at height ``z``.

    The patch is one solid (``tessellated`` / ``multiunion``: the closed body, slab below the
    base plane), a grid of closed blocks (``blocks``, :mod:`.blocks`) or a spike grid's base box
    and frustums placed side by side (``frustums``, :mod:`.frustums`).
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
        )
    if kind == "frustums":
        assert surface.spikes is not None  # only spike grids are made of frustums
        return place_frustums(
            g4, surface.spikes, layer.base_thickness, material, mother_lv, z, name
        )
    if kind == "multiunion":
        assert surface.spikes is not None  # only spike grids are made multi-unions
        solid, parts = multiunion_solid(g4, surface.spikes, layer.base_thickness, name)
    else:
        solid, parts = tessellated_solid(g4, surface.body(layer.base_thickness), name), []
    lv = g4.G4LogicalVolume(solid, material, name)
    pv = g4.G4PVPlacement(
        None, g4.G4ThreeVector(0, 0, z), lv, name, mother_lv, False, copy_no, False
    )
    return [lv], [solid, parts, lv, pv]


def place_native(
    g4, layer: RoughLayer, mother_lv, world_material, material, frame: FaceFrame | None = None
) -> tuple[list, list]:
    """Place the layer's envelope in ``mother_lv`` and the patches in it.

    ``world_material`` is the material around the patches (the mother's); ``frame`` is the
    face frame in the mother's coordinates (default: ``layer.frame``, the world's). Cells without
    patch (``layer.mask``) stay empty. Returns ``(patch logical volumes, objects to keep alive)``.
    """
    frame = frame or layer.frame
    lu, lv = frame.size
    t = layer.thickness
    name = layer.name
    prism = layer.envelope_prism()  # a polygon face or kept cells: the envelope is a prism
    ring = getattr(layer, "ring", None)  # a round face: the envelope is its ring
    if prism is not None:
        env_solid = tessellated_solid(g4, prism, name)
    elif ring is not None:
        env_solid = g4.G4Tubs(name, ring[0], ring[1], t / 2, 0.0, 2 * np.pi)
    else:
        env_solid = g4.G4Box(name, lu / 2, lv / 2, t / 2)
    env_lv = g4.G4LogicalVolume(env_solid, world_material, name)
    rot = _rotation(g4, frame.rotation)
    centre = frame.to_world(np.array([0.0, 0.0, t / 2]))
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
        lvs_k, keep_k = place_variant(g4, layer, k, cell_lv, z, material, f"{name}_v{k}")
        keep += [cell_solid, cell_lv, keep_k]
        patch_lvs += lvs_k
        cell_lvs.append(cell_lv)
    variants = layer.cell_variants
    ny, nx = variants.shape
    empty = -1
    if (variants < 0).any():  # cells without patch: an empty cell box (keeps the grid regular)
        empty_solid = g4.G4Box(f"{name}_empty", px / 2, py / 2, t / 2)
        empty_lv = g4.G4LogicalVolume(empty_solid, world_material, f"{name}_empty")
        keep += [empty_solid, empty_lv]
        cell_lvs.append(empty_lv)
        empty = len(cell_lvs) - 1
        variants = np.where(variants < 0, empty, variants)
    if layer.config.native_layout == "replicas":
        # rows of cells along y in the envelope, cells along x in each row: two replica levels
        row_solid = g4.G4Box(f"{name}_row", lu / 2, py / 2, t / 2)
        row_lv = g4.G4LogicalVolume(row_solid, world_material, f"{name}_row")
        rows = g4.G4PVReplica(f"{name}_row", row_lv, env_lv, g4.EAxis.kYAxis, ny, py, 0.0)
        cells = g4.G4PVReplica(f"{name}_cell", cell_lvs[0], row_lv, g4.EAxis.kXAxis, nx, px, 0.0)
        keep += [row_solid, row_lv, rows, cells]
        return patch_lvs, keep
    layout = layer.config.native_layout
    if prism is not None or ring is not None:
        layout = "placements"  # boxes of empty cells would leave the polygon or the ring
    if layout == "nested" or (layout == "auto" and variants.size > MAX_DAUGHTERS):
        # nested at any size: at most 4 boxes in the envelope (deep trees, for tests)
        most = MAX_DAUGHTERS if layout == "auto" else 4
        keep += place_nested(
            g4, variants, cell_lvs, (px, py, t), env_lv, world_material, name, most
        )
        return patch_lvs, keep
    centres = layer.cell_centres()
    for j in range(ny):
        for i in range(nx):
            if variants[j, i] == empty:  # placements: an empty cell is simply left out
                continue
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
    # The cell boxes a region of their own: the walk before each BeamOn then visits each
    # variant's patch once, not once per cell (patches of placed frustums hold ~2500 volumes).
    keep += level_regions(g4, [cell_lvs], name)
    return patch_lvs, keep


def _unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(index of the first occurrence of each distinct row, row -> distinct id) of an int matrix.

    Columns are merged pairwise through integer keys (fast for millions of short rows).
    """
    cols = [rows[:, c] + 1 for c in range(rows.shape[1])]  # ids >= -1 -> >= 0
    while len(cols) > 1:
        merged = []
        for a, b in zip(cols[0::2], cols[1::2], strict=False):
            pair = a.astype(np.int64) * (int(b.max()) + 1) + b  # no overflow of int32 ids
            _, key = np.unique(pair, return_inverse=True)
            merged.append(key.ravel().astype(np.int32))
        if len(cols) % 2:
            merged.append(cols[-1])
        cols = merged
    _, first, inverse = np.unique(cols[0], return_index=True, return_inverse=True)
    return first, inverse.ravel()


def group_grid(ids: np.ndarray, g: int) -> tuple[np.ndarray, np.ndarray]:
    """Group a grid of box ids ``g`` x ``g``: ``(patterns, grid)``.

    ``ids[j, i]`` (row ``j`` along y) holds non-negative box ids. ``patterns[m]`` is the
    ``(g, g)`` block of child ids of group ``m`` (``[dj, di]``; -1 where a group on the far edge
    of the grid has no child), one per distinct block; ``grid[J, I]`` is the pattern of the
    group holding boxes ``[gJ:gJ+g, gI:gI+g]``.
    """
    ny, nx = ids.shape
    gy, gx = -(-ny // g), -(-nx // g)
    # int32 (ids are variant and pattern numbers): a 10 m^2 face has 4e7 cells, 160 MB a copy
    padded = np.full((gy * g, gx * g), -1, dtype=np.int32)
    padded[:ny, :nx] = ids
    blocks = padded.reshape(gy, g, gx, g).transpose(0, 2, 1, 3).reshape(gy * gx, g * g)
    first, inverse = _unique_rows(blocks)
    return blocks[first].reshape(-1, g, g), inverse.reshape(gy, gx)


def grouping_plan(
    variants: np.ndarray, max_daughters: int = MAX_DAUGHTERS, budget: int = PLACEMENT_BUDGET
) -> list[tuple]:
    """The levels of groups :func:`place_nested` places for ``variants``: ``(g, patterns, grid)``
    per level, as :func:`group_grid` returns them for that level's factor ``g``.

    At each level: if one grouping of ``g`` x ``g`` boxes (the smallest ``g`` that leaves at most
    ``max_daughters`` groups for the envelope) needs at most ``budget``
    placements (distinct groups x ``g``^2; groups with the same content share one logical
    volume), it is the last level. Otherwise the level groups 2 x 2 (sharing most where the
    patterns repeat) and the next level decides again. Few levels keep navigation fast; a face
    of one variant always gets a single level.
    """
    ids = np.asarray(variants, dtype=np.int32)
    plan: list[tuple] = []
    while ids.size > max_daughters:
        g = 2
        while -(-ids.shape[0] // g) * -(-ids.shape[1] // g) > max_daughters:
            g += 1
        patterns, grid = group_grid(ids, g)
        if g > 2 and len(patterns) * g * g > budget:
            g = 2
            patterns, grid = group_grid(ids, g)
        plan.append((g, patterns, grid))
        ids = grid
    return plan


def place_nested(
    g4,
    variants: np.ndarray,
    cell_lvs: list,
    cell: tuple,
    env_lv,
    world_material,
    name: str,
    max_daughters: int = MAX_DAUGHTERS,
    budget: int = PLACEMENT_BUDGET,
) -> list:
    """Place the cells of ``variants`` in ``env_lv`` as nested groups (see the module doc).

    ``cell`` is ``(px, py, t)``, the cell box size. The levels come from :func:`grouping_plan`
    (``max_daughters``, ``budget``); a group on the far edge of a grid that is not a multiple
    of the level's factor holds fewer boxes. One logical volume per distinct group; the
    envelope holds the last level.
    Returns the Geant4 solids and logical volumes to keep alive; the placements themselves belong
    to Geant4 (their mothers) and no Python object is kept per placement.
    """
    px, py, t = cell
    vec = g4.G4ThreeVector
    lvs = list(cell_lvs)
    span_x = [1] * len(lvs)  # cells covered by box id, along x and y
    span_y = [1] * len(lvs)
    ids = np.asarray(variants, dtype=np.int32)
    keep: list = []
    levels = [list(cell_lvs)]  # the distinct volumes of each level, cells first
    size = 1  # cells per box side at the current level (full boxes)
    below = 0  # id of the first box of the level below (the plan numbers each level from 0)
    for level, (g, patterns, grid) in enumerate(grouping_plan(ids, max_daughters, budget), start=1):
        first_id = len(lvs)
        for m, block in enumerate((patterns + below * (patterns >= 0)).tolist()):
            # block[dj][di]; the columns' widths and the rows' heights, in cells
            widths = [span_x[b] for b in block[0] if b >= 0]
            heights = [span_y[row[0]] for row in block if row[0] >= 0]
            w, h = sum(widths), sum(heights)
            x0 = np.concatenate([[0], np.cumsum(widths)])
            y0 = np.concatenate([[0], np.cumsum(heights)])
            tag = f"{name}_g{level}_{m}"
            solid = g4.G4Box(tag, w * px / 2, h * py / 2, t / 2)
            lv = g4.G4LogicalVolume(solid, world_material, tag)
            for dj, row in enumerate(block):
                for di, child in enumerate(row):
                    if child < 0:
                        continue
                    x = (-w / 2 + x0[di] + widths[di] / 2) * px
                    y = (-h / 2 + y0[dj] + heights[dj] / 2) * py
                    g4.G4PVPlacement(
                        None,
                        vec(float(x), float(y), 0.0),
                        lvs[child],
                        tag,
                        lv,
                        False,
                        dj * g + di,
                        False,
                    )
            keep += [solid, lv]
            lvs.append(lv)
            span_x.append(w)
            span_y.append(h)
        levels.append(lvs[first_id:])
        ids = grid + first_id
        below = first_id
        size *= g
    # the envelope holds the last level: box (I, J) starts at cell (I * size, J * size)
    ny, nx = ids.shape
    lu, lv_ = sum(span_x[k] for k in ids[0]) * px, sum(span_y[k] for k in ids[:, 0]) * py
    for j in range(ny):
        for i in range(nx):
            k = int(ids[j, i])
            x = -lu / 2 + (i * size + span_x[k] / 2) * px
            y = -lv_ / 2 + (j * size + span_y[k] / 2) * py
            g4.G4PVPlacement(
                None, vec(x, y, 0.0), lvs[k], f"{name}_top", env_lv, False, j * nx + i, False
            )
    keep += level_regions(g4, levels, name)
    return keep


def level_regions(g4, levels: list[list], name: str) -> list:
    """One Geant4 region per level of distinct volumes (cells first), as their root volumes.

    Before every ``BeamOn`` Geant4 sets the material-cuts couple of each logical volume by a walk
    down the volume tree from each region's root volumes, once per material, that stops only at
    volumes of another region (``G4ProductionCutsTable::ScanAndSetCouple``): through shared
    groups it visits every cell of the face, 4 million times per material on a 1 m face. With
    each level its own region, each walk stops one level down. The regions get the default
    production cuts (Geant4 gives a region without cuts the world's), so the physics is the
    same.
    """
    regions = []
    for n, lvs in enumerate(levels):  # bottom-up: a new root's walk stops at the roots below
        region = g4.G4Region(f"{name}_level{n}")
        for lv in lvs:  # distinct volumes: skip Geant4's search of the root list (quadratic)
            region.AddRootLogicalVolume(lv, False)
        regions.append(region)
    return regions
