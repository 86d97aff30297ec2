"""Bent patch bodies on cones: the floor strip against the body Geant4 gets now (issue 24).

    .venv/bin/python benchmarks/bench_facet_split.py [--rounds 3] [--points 20000]

Two cones with ``solid: tessellated`` cells of spike grids (10 um pyramids): r 2 -> 2.25 mm over
5 mm with 50 x 50 spikes on 0.5 mm patches, and r 3 -> 4 mm over 2 mm with 10 x 10 spikes on
0.1 mm patches. For ring 1's body of each, three meshes of one surface:
  strip       the floor as a strip between its long edges, fans at its short sides (before)
  reordered   the same facets, each wall and floor facet's corners turned so Geant4's P0 faces
              its longest edge (score4.surface.triangle_mesh.longest_edge_last)
  grid        the body Geant4 gets (score4.world.curved.solid_body: the floor in spike-width
              squares, and turned as above)
and for each:
  facets      number of triangles
  tol nm      the largest distance beyond a facet's edge that G4TriangularFacet::Intersect
              still accepts (score4.surface.triangle_mesh.intersect_tolerance)
  false in    of --points probe points 3-30 nm outside the walls and floor (exactly: the
              winding number of score4.shapes.MeshShape, more than 2 nm outside), those that
              G4TessellatedSolid::Inside calls kInside (the same points for all three meshes)
  numpy ms    CPU to make the mesh from the flat strip body (solid_body; 0 for the strip)
  G4 ms       CPU to build and close the G4TessellatedSolid (median of --rounds, interleaved)
  G4 MB       G4TessellatedSolid::AllocatedMemory (facets and voxels)
Figures of past runs: benchmarks/README.md, section bench_facet_split.py.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

CASES = {
    "cone r 2-2.25 mm, 50x50 spikes": (2.0, 2.25, 2.5, 50),
    "cone r 3-4 mm, 10x10 spikes": (3.0, 4.0, 1.0, 10),
}


def write_cone(path: Path, r1: float, r2: float, half_z: float) -> None:
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Cons("cyl_s", 0, r1, 0, r2, 2 * half_z, 0, 2 * math.pi, reg)
    lv = pg.geant4.LogicalVolume(solid, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))


def layer_of(tmp: Path, r1: float, r2: float, half_z: float, n: int):
    from score4.inputs.config import parse_config
    from score4.world.resolve import build_scene

    gdml = tmp / f"cone_{r1}_{r2}.gdml"
    write_cone(gdml, r1, r2, half_z)
    surface = {"kind": "spikes", "nx": n, "ny": n, "width": "10 um", "height": "10 um"}
    config = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": surface},
        "targets": [
            {"volume": "cyl", "rough": [{"face": "outer", "surface": "p", "solid": "tessellated"}]}
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "cyl", "face": "outer"},
        },
        "run": {"events": 1, "seed": 1},
    }
    return build_scene(parse_config(config)).layers[0]


def probe_points(v: np.ndarray, f: np.ndarray, n_top: int, n: int) -> np.ndarray:
    """Points 3-30 nm off the walls and floor (facets after the top), more than 2 nm outside."""
    from score4.shapes.mesh_shape import MeshShape

    rng = np.random.default_rng(7)
    tri = v[f]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(normal, axis=1)
    normal /= area[:, None]
    rest = np.arange(n_top, len(f))
    by_area = rng.choice(rest, n, p=area[rest] / area[rest].sum())
    pick = np.where(rng.random(n) < 0.5, by_area, rng.choice(rest, n))  # walls get their share
    r1, r2 = rng.random(n), rng.random(n)
    over = r1 + r2 > 1
    r1[over], r2[over] = 1 - r1[over], 1 - r2[over]
    out = normal[pick] + 0.3 * rng.normal(size=(n, 3))
    out /= np.linalg.norm(out, axis=1)[:, None]
    t = tri[pick]
    p = t[:, 0] + r1[:, None] * (t[:, 1] - t[:, 0]) + r2[:, None] * (t[:, 2] - t[:, 0])
    p += rng.uniform(3e-6, 30e-6, n)[:, None] * out
    return p[MeshShape(tri).signed_distance(p) > 2e-6]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--points", type=int, default=20000)
    args = ap.parse_args()

    from score4.geometry.solids import tessellated_solid
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.triangle_mesh import TriangleMesh, intersect_tolerance, longest_edge_last
    from score4.world.curved import solid_body

    g4 = import_geant4(resolve_physics("lite"))
    with open("/proc/loadavg") as fh:
        print(f"load {fh.read().split()[0]}")
    with tempfile.TemporaryDirectory() as tmp:
        for case, (r1, r2, half_z, n) in CASES.items():
            layer = layer_of(Path(tmp), r1, r2, half_z, n)
            lay, j = layer.ring_layout, 1
            offset = layer.base_thickness + layer.lift
            flat = layer._flat(0)
            v0, f0, n_top = flat
            meshes = {"strip": (v0, f0, 0.0)}
            t0 = time.process_time()
            turned = longest_edge_last(v0, f0[n_top:])
            meshes["reordered"] = (v0, np.vstack([f0[:n_top], turned]), time.process_time() - t0)
            t0 = time.process_time()
            v1, f1, _ = solid_body(flat, layer.variants[0], layer.base_thickness)
            meshes["grid"] = (v1, f1, time.process_time() - t0)
            bent = {k: (lay.bend(v, j, offset), f) for k, (v, f, _) in meshes.items()}
            points = probe_points(*bent["strip"], n_top, args.points)
            g4_cpu: dict[str, list[float]] = {k: [] for k in meshes}
            solids = {}
            for r in range(args.rounds):
                for k, (v, f) in bent.items():
                    t0 = time.process_time()
                    solid = tessellated_solid(g4, TriangleMesh(v, f), f"{k}_{r}_{case[:8]}")
                    g4_cpu[k].append(time.process_time() - t0)
                    solids[k] = solid
            print(f"\n{case} (ring {j}); {len(points)} probe points 3-30 nm outside")
            print(f"{'mesh':10s} {'facets':>7s} {'tol nm':>8s} {'false in':>9s} "
                  f"{'numpy ms':>9s} {'G4 ms':>7s} {'G4 MB':>7s}")  # fmt: skip
            for k, (v, f) in bent.items():
                solid = solids[k]
                wrong = sum(
                    solid.Inside(g4.G4ThreeVector(*q)) == g4.EInside.kInside for q in points
                )
                tol = float(intersect_tolerance(v[f]).max()) * 1e6
                print(
                    f"{k:10s} {len(f):7d} {tol:8.3g} {wrong:9d} {meshes[k][2] * 1e3:9.1f} "
                    f"{float(np.median(g4_cpu[k])) * 1e3:7.1f} {solid.AllocatedMemory() / 1e6:7.2f}"
                )


if __name__ == "__main__":
    main()
