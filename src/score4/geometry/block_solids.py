"""Rough patches as a grid of small closed tessellated blocks in Geant4 (``solid: blocks``).

The cut itself (pure numpy, exact) is :mod:`score4.surface.block_cut`; this module turns the
blocks into volumes placed side by side in the patch's mother volume: each block's rough cap a
``G4TessellatedSolid``, the floor under it a ``G4Box``.
"""

from __future__ import annotations

import numpy as np

from score4.surface.block_cut import block_caps
from score4.surface.triangle_mesh import TriangleMesh

from ..surface.rough import Surface

#: Voxels Geant4 may give each cap of a simplified map (``G4TessellatedSolid::SetMaxVoxels``;
#: -1: Geant4's own choice, about one per facet candidate; 0: none). A voxelised solid keeps
#: ~100 bytes per facet whatever its voxels (its per-facet boxes), and more voxels cost more.
#: Measured on the 1024 x 1024 Gaussian map at 0.1 um (15 559 caps of 687 k facets, cut in
#: four; the caps alone in Geant4, resident memory; instructions per alpha event,
#: bench_instructions.py --set, 300 events): Geant4's choice 369 MB and 4.347 M (1.058x the
#: pyramid face), 27 voxels 346 MB, 8 voxels 308 MB and 4.425 M (1.077x), none 250 MB and
#: 5.205 M (1.267x: every safety then measures every facet). Exact maps keep Geant4's choice.
SIMPLIFIED_CAP_VOXELS = 8
#: The same for the caps of an exact height map with at most :data:`SMALL_CAP_FACETS` facets (the
#: 2 x 2 and 3 x 3-pixel blocks); -1, the default: Geant4's own. Each step inside a cap asks for
#: its exact safety, which Geant4 finds by sorting the solid's voxel boxes by distance and
#: measuring the facets of each box; a 2 x 2-pixel cap has 22 facets, all within ~1 um of any
#: point in it, so its 5-12 boxes prune nothing and the sort and box distances are ~37 % of the
#: safety's cost. 4 voxels give the same safety for less work: bench_instructions.py, 1.5 mm
#: face, self-affine map 5.095 -> 4.948 M instructions per alpha event (Gaussian 4.638 -> 4.467,
#: measured 4.559 -> 4.442). Not the default: CPU per event did not follow (bench_surfaces.py at
#: 3 cm, 3 interleaved rounds, load 2.9: 0.802 against 0.745 ms), and a distance along a ray
#: then meets other facets first, so Geant4's facet tolerance shows on other rays (3 of 2760
#: geantino paths on a self-affine map moved, by up to 0.6 um; on blocks of bumps with a height
#: spread 1.7 % of straight-down geantinos ended > 1e-9 mm off, so spike grids are left out).
#: benchmarks/README.md, session 11; try it with bench_instructions.py
#: ``--set score4.geometry.block_solids.CAP_MAX_VOXELS=4``.
CAP_MAX_VOXELS = -1
#: Facets of the largest cap :data:`CAP_MAX_VOXELS` applies to.
SMALL_CAP_FACETS = 40
#: Voxels of the larger caps of an exact height map (more than :data:`SMALL_CAP_FACETS` facets:
#: maps of more than 256 x 256 pixels, whose automatic blocks are larger than 2 x 2 pixels, or
#: an explicit ``block_cells`` of 4 or more); -1, the default: Geant4's own choice. Measured
#: (benchmarks/README.md, session 13): the exact 1024 x 1024 noise-like map, 2.72 M facets in
#: 16 384 caps of 166 (bench_surfaces.py --stages 1024 --map noise --tolerance auto --set ...):
#: Geant4's voxels peak 1692 MB, 25.8 s; 8 voxels 1406 MB, 23.2 s; none 1178 MB, 21.1 s.
#: Instructions per alpha event on 8 x 8-pixel caps of the self-affine example
#: (bench_instructions.py --cases selfaff_blocks_b8): Geant4's voxels 9.600 M, 8 voxels 9.538 M,
#: none 14.387 M. Not the default: on test_blocks.py's geantino rays through 8 x 8-pixel blocks
#: of its random map, 8 voxels put 21 of 2040 rays more than 2e-5 mm farther from the exact
#: mesh than one tessellated solid, Geant4's voxels 17 (both fail that test's rule).
LARGE_CAP_VOXELS = -1


def fast_tessellated(g4, mesh: TriangleMesh, name: str, max_voxels: int = -1):
    """A closed G4TessellatedSolid of ``mesh``; one G4ThreeVector per vertex, shared by its
    faces. ``max_voxels`` >= 0 bounds the solid's voxels (-1: Geant4's default)."""
    return tessellated(g4, mesh.vertices, mesh.faces.tolist(), name, max_voxels)


def tessellated(g4, vertices: np.ndarray, faces: list, name: str, max_voxels: int = -1):
    """:func:`fast_tessellated` of a vertex array and a list of vertex-id triples."""
    solid = g4.G4TessellatedSolid(name)
    if max_voxels >= 0:
        solid.SetMaxVoxels(max_voxels)
    vec, facet, absolute = g4.G4ThreeVector, g4.G4TriangularFacet, g4.ABSOLUTE
    points = [vec(*p) for p in vertices.tolist()]
    add = solid.AddFacet
    for a, b, c in faces:
        add(facet(points[a], points[b], points[c], absolute))
    solid.SetSolidClosed(True)
    return solid


def place_blocks(
    g4,
    surface: Surface,
    base_thickness: float,
    block_cells: int | None,
    material,
    mother_lv,
    z: float,
    name: str,
) -> tuple[list, list]:
    """Place the patch's blocks in ``mother_lv``, base plane at height ``z`` of the mother.

    Each block is its tessellated cap on a box, its floor (``block_cut.floored_blocks``, as
    :func:`~score4.surface.block_cut.block_caps` gives them).
    Returns ``(logical volumes of the blocks, objects to keep alive)``; all logical volumes
    are of ``material`` and belong to the patch's scoring group.
    """
    lvs, keep = [], []
    vec = g4.G4ThreeVector
    where = vec(0.0, 0.0, z)
    keep.append(where)
    voxels = -1 if surface.quad_cells is None else SIMPLIFIED_CAP_VOXELS
    exact_map = surface.quad_cells is None and surface.spikes is None
    for b, (vertices, faces, floor) in enumerate(block_caps(surface, base_thickness, block_cells)):
        small = len(faces) <= SMALL_CAP_FACETS
        cap_voxels = (CAP_MAX_VOXELS if small else LARGE_CAP_VOXELS) if exact_map else voxels
        solid = tessellated(g4, vertices, faces, f"{name}_b{b}", cap_voxels)
        lv = g4.G4LogicalVolume(solid, material, f"{name}_b{b}")
        pv = g4.G4PVPlacement(None, where, lv, f"{name}_b{b}", mother_lv, False, b, False)
        lvs.append(lv)
        keep += [solid, lv, pv]
        if floor is None:
            continue
        (x0, y0, z0), (x1, y1, z1) = floor.tolist()
        box = g4.G4Box(f"{name}_f{b}", (x1 - x0) / 2, (y1 - y0) / 2, (z1 - z0) / 2)
        lv = g4.G4LogicalVolume(box, material, f"{name}_f{b}")
        at = vec((x0 + x1) / 2, (y0 + y1) / 2, z + (z0 + z1) / 2)
        pv = g4.G4PVPlacement(None, at, lv, f"{name}_f{b}", mother_lv, False, b, False)
        lvs.append(lv)
        keep += [box, lv, pv, at]
    return lvs, keep
