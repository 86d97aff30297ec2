"""Write pyg4ometry_tessellated.gdml with pyg4ometry: a GDML file from a tool that is not Geant4.

pyg4ometry is NOT a score4 dependency. Run this once, in a scratch environment:

    python3.11 -m venv /tmp/pyg4 && /tmp/pyg4/bin/pip install pyg4ometry==1.4.6
    /tmp/pyg4/bin/python tests/data/gdml/make_pyg4ometry_gdml.py

(the committed file was written with pyg4ometry 1.4.6, Python 3.11.7). tests/test_gdml_import.py
reads it with score4.geometry.gdml.read_gdml and checks it against the numbers defined here.

The solid is a small rough body, all lengths in mm:
- a slab x, y in [-15, 15], z in [-5, 0];
- on it a 3 x 3 grid of square pyramids, each with a 10 x 10 base filling its cell and its apex
  above the cell centre, at the heights in HEIGHTS (row-major, y outer, x inner, from -y, -x);
- facets: 36 triangles (pyramid sides), 12 quadrangles (walls, one per pyramid edge so no
  T-junctions) and 9 quadrangles (bottom, on the same 10 mm grid): 57 facets, 4 x 4 + 9 + 16
  vertices. Volume = 30 * 30 * 5 + (100 / 3) * sum(HEIGHTS) = 4500 + 1500 = 6000 mm^3.
The body (material G4_Si) sits in a 60 x 60 x 40 mm G4_Galactic world box, translated by
PLACEMENT. Facets are written by pyg4ometry's Writer ("Freecad" mesh type: named <position>
defines, <triangular> and <quadrangular> facets, vertices anticlockwise seen from outside).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HEIGHTS = np.array([[3.0, 7.0, 5.0], [8.0, 2.0, 6.0], [4.0, 9.0, 1.0]])  # [iy, ix], mm
CELL = 10.0
THICKNESS = 5.0
PLACEMENT = (0.0, 0.0, 2.0)
WORLD = (60.0, 60.0, 40.0)  # full lengths


def rough_body() -> tuple[np.ndarray, list[list[int]]]:
    """Vertices (n, 3) and facets (vertex index lists, anticlockwise seen from outside)."""
    edges = CELL * (np.arange(4) - 1.5)  # -15, -5, 5, 15
    vertices: list[tuple[float, float, float]] = []

    def vid(p) -> int:
        vertices.append(tuple(float(c) for c in p))
        return len(vertices) - 1

    top = {
        (i, j): vid((edges[i], edges[j], 0.0)) for j in range(4) for i in range(4)
    }  # grid at z=0
    low = {(i, j): vid((edges[i], edges[j], -THICKNESS)) for j in range(4) for i in range(4)}
    facets: list[list[int]] = []
    for j in range(3):
        for i in range(3):
            apex = vid((edges[i] + CELL / 2, edges[j] + CELL / 2, HEIGHTS[j, i]))
            a, b, c, d = (
                top[i, j],
                top[i + 1, j],
                top[i + 1, j + 1],
                top[i, j + 1],
            )  # anticlockwise from +z
            facets += [[a, b, apex], [b, c, apex], [c, d, apex], [d, a, apex]]
            facets.append(
                [low[i, j], low[i, j + 1], low[i + 1, j + 1], low[i + 1, j]]
            )  # bottom, seen from -z
    for k in range(3):  # walls, one quad per cell edge: the four sides of the square outline
        facets.append([top[k, 0], low[k, 0], low[k + 1, 0], top[k + 1, 0]])  # y = -15, normal -y
        facets.append([top[3, k], low[3, k], low[3, k + 1], top[3, k + 1]])  # x = +15, normal +x
        facets.append([top[k + 1, 3], low[k + 1, 3], low[k, 3], top[k, 3]])  # y = +15, normal +y
        facets.append([top[0, k + 1], low[0, k + 1], low[0, k], top[0, k]])  # x = -15, normal -x
    return np.array(vertices), facets


def check(vertices: np.ndarray, facets: list[list[int]]) -> float:
    """Closed and outward-oriented: every directed edge once, positive divergence volume."""
    directed = [(f[k], f[(k + 1) % len(f)]) for f in facets for k in range(len(f))]
    assert len(set(directed)) == len(directed), "an edge is used twice in the same direction"
    assert {(b, a) for a, b in directed} == set(directed), "the surface is not closed"
    volume = 0.0
    for f in facets:
        for k in range(1, len(f) - 1):  # fan triangles of the facet
            p, q, r = vertices[f[0]], vertices[f[k]], vertices[f[k + 1]]
            volume += np.dot(p, np.cross(q, r)) / 6.0
    expected = 30 * 30 * THICKNESS + CELL * CELL / 3 * HEIGHTS.sum()
    assert abs(volume - expected) < 1e-9, (volume, expected)
    return volume


def main() -> None:
    from importlib.metadata import version

    import pyg4ometry

    g4 = pyg4ometry.geant4
    vertices, facets = rough_body()
    check(vertices, facets)
    reg = g4.Registry()
    world_solid = g4.solid.Box("world", *WORLD, reg)
    world_lv = g4.LogicalVolume(world_solid, "G4_Galactic", "world_lv", reg)
    mesh = [[list(v) for v in vertices], facets]
    body = g4.solid.TessellatedSolid("rough", mesh, reg, g4.solid.TessellatedSolid.MeshType.Freecad)
    body_lv = g4.LogicalVolume(body, "G4_Si", "rough_lv", reg)
    g4.PhysicalVolume([0, 0, 0], list(PLACEMENT), body_lv, "rough_pv", world_lv, reg)
    reg.setWorld(world_lv.name)
    writer = pyg4ometry.gdml.Writer()
    writer.addDetector(reg)
    out = Path(__file__).with_name("pyg4ometry_tessellated.gdml")
    writer.write(str(out))
    print(
        f"wrote {out}: {len(facets)} facets, {len(vertices)} vertices, pyg4ometry "
        f"{version('pyg4ometry')}"
    )


if __name__ == "__main__":
    main()
