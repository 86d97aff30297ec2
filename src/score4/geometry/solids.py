"""Geant4 solids built from score4 surfaces.

Both builders start from the same description the vertex sampler uses (the exact mesh, or the
spike grid's frustums), so geometry and sampling cannot disagree.
"""

from __future__ import annotations

import numpy as np

from score4.surface.triangle_mesh import TriangleMesh

from ..surface.spikes import SpikeGrid

#: Above this many facets a tessellated solid gets at most TESSELLATED_MAX_VOXELS voxels: fewer,
#: larger voxels halved tracking time and memory at 3e5 spikes (benchmarks/bench_solids.py).
TESSELLATED_VOXEL_LIMIT_FACETS = 40_000
TESSELLATED_MAX_VOXELS = 10_000


def tessellated_solid(g4, mesh: TriangleMesh, name: str):
    """A closed G4TessellatedSolid with one triangular facet per mesh face (outward normals)."""
    solid = g4.G4TessellatedSolid(name)
    if mesh.n_faces > TESSELLATED_VOXEL_LIMIT_FACETS:
        solid.SetMaxVoxels(TESSELLATED_MAX_VOXELS)
    corners = mesh.vertices[mesh.faces]
    vec = g4.G4ThreeVector
    for a, b, c in corners:
        solid.AddFacet(g4.G4TriangularFacet(vec(*a), vec(*b), vec(*c), g4.ABSOLUTE))
    solid.SetSolidClosed(True)
    return solid


def multiunion_solid(g4, grid: SpikeGrid, thickness: float, name: str):
    """The paper's construction: a base box under z = 0 plus one G4Trd per spike layer.

    Returns ``(solid, parts)``; keep ``parts`` (the node solids) alive as long as the solid.
    """
    union = g4.G4MultiUnion(name)
    parts = []
    base = g4.G4Box(f"{name}_base", grid.size_x / 2, grid.size_y / 2, thickness / 2)
    union.AddNode(
        base, g4.G4Transform3D(g4.G4RotationMatrix(), g4.G4ThreeVector(0, 0, -thickness / 2))
    )
    parts.append(base)
    f = grid.frustums()
    for k in range(len(f)):
        trd = g4.G4Trd(
            f"{name}_{k}",
            f["width_x_bottom"][k] / 2,
            f["width_x_top"][k] / 2,
            f["width_y_bottom"][k] / 2,
            f["width_y_top"][k] / 2,
            f["height"][k] / 2,
        )
        where = g4.G4ThreeVector(float(f["x"][k]), float(f["y"][k]), float(f["z"][k]))
        union.AddNode(trd, g4.G4Transform3D(g4.G4RotationMatrix(), where))
        parts.append(trd)
    union.Voxelize()
    return union, parts


def inside_codes(g4, solid, points: np.ndarray) -> np.ndarray:
    """Geant4's EInside for each point: 0 outside, 1 on the surface, 2 inside."""
    vec = g4.G4ThreeVector
    codes = {g4.EInside.kOutside: 0, g4.EInside.kSurface: 1, g4.EInside.kInside: 2}
    return np.array([codes[solid.Inside(vec(*p))] for p in points], dtype=np.int8)
