"""What the overlaps Geant4 reports on a rough G4Cons face are: each reported point, probed.

    .venv/bin/python tools/figures/cone_overlaps.py

Writes a small G4Cons (radius 3 -> 4 mm over 0.6 mm, 0.3 rad of phi) with 10 um pyramids on its
``outer`` face, runs ``score4 geometry check`` on it (Geant4's CheckOverlaps on every bent patch,
1000 points each) and, for every overlap Geant4 reports ("overlap at local point P by D nm"
between cells A and B; P is in B's frame), asks the body of cell B about P: its exact distance
from B's triangles (numpy), whether score4's ray parity finds P inside, and Geant4's own
``G4TessellatedSolid`` of the same triangles: ``Inside(P)`` with score4's voxels and with 10^6
voxels, ``DistanceToIn(P)``, and ``Inside`` 100 nm either side of P. Then 3000 random points
50-1000 nm outside B's side wall, to see whether Geant4 misclassifies points there in general.
Checked by docs/geometry.md (check ``cone-overlaps``).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from score4.inputs.config import load_config
from score4.shapes.mesh_shape import _tri_distance
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

REPORT = re.compile(
    r"volume (\S+):(\d+) \(G4TessellatedSolid\) with \S+:(\d+) \(G4TessellatedSolid\)\s+"
    r"overlap at local point \(([-\d.e]+),([-\d.e]+),([-\d.e]+)\) by ([\d.]+) (nm|um|mm)"
)


def write_cone(folder: Path) -> Path:
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    solid = pg.geant4.solid
    world = pg.geant4.LogicalVolume(solid.Box("w", 100, 100, 100, reg), "G4_Galactic", "W", reg)
    cone = solid.Cons("c", 0, 3.0, 0, 4.0, 0.6, 0, 0.3, reg)
    lv = pg.geant4.LogicalVolume(cone, "G4_Si", "C", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "cone", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(folder / "cone.gdml"))
    pyramids = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
    data = {
        "physics": "lite",
        "world": {"gdml": "cone.gdml"},
        "surfaces": {"p": pyramids},
        "targets": [
            {"volume": "cone", "rough": [{"face": "outer", "surface": "p", "solid": "tessellated"}]}
        ],
        "source": {"particle": "geantino", "energy": "1 MeV", "surface": {"volume": "cone"}},
        "run": {"events": 10, "seed": 3},
    }
    (folder / "cone.yaml").write_text(yaml.safe_dump(data))
    return folder / "cone.yaml"


def g4_body(g4, vertices: np.ndarray, faces: np.ndarray, max_voxels: int | None, name: str):
    vec = g4.G4ThreeVector
    solid = g4.G4TessellatedSolid(name)
    if max_voxels is not None:
        solid.SetMaxVoxels(max_voxels)
    for a, b, c in vertices[faces]:
        solid.AddFacet(g4.G4TriangularFacet(vec(*a), vec(*b), vec(*c), g4.ABSOLUTE))
    solid.SetSolidClosed(True)
    return solid


def main() -> None:
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    from score4.geometry.solids import tessellated_solid
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.triangle_mesh import TriangleMesh

    with tempfile.TemporaryDirectory() as tmp:
        cfg = write_cone(Path(tmp))
        check = subprocess.run(
            [sys.executable, "-m", "score4", "geometry", "check", cfg.name],
            cwd=tmp,
            capture_output=True,
            text=True,
        )
        reports = REPORT.findall(check.stdout + check.stderr)
        scene = build_scene(load_config(cfg))
    layer = scene.layers[0]
    assert isinstance(layer, CurvedRoughLayer)
    cells = layer.cells()
    lay = layer.ring_layout
    print(f"Geant4 reports {len(reports)} overlap(s) among {len(cells)} bent patches")
    g4 = import_geant4(resolve_physics("lite"))
    vec = g4.G4ThreeVector
    for _, a, b, x, y, z, by, unit in reports:
        j, _, k, _ = cells[int(b)]
        body = layer.bent(k, j)
        p = np.array([float(x), float(y), float(z)])
        tri = body.vertices[body.faces]
        dist = float(_tri_distance(p[None], tri).min())
        inside_np = bool(layer.contains(p[None])[0])  # the cone sits at the world's origin
        ours = tessellated_solid(g4, TriangleMesh(body.vertices, body.faces), "ours")
        fine = g4_body(g4, body.vertices, body.faces, 10**6, "fine")
        side = [
            str(ours.Inside(vec(*(p + np.array([0, s, 0]))))).split(".")[-1] for s in (-1e-4, 1e-4)
        ]
        print(f"cells {a} / {b}: reported overlap {by} {unit}")
        print(f"  exact distance of the point from cell {b}'s body: {dist * 1e6:.4g} nm")
        print(f"  score4 ray parity: {'inside' if inside_np else 'outside'}")
        print(f"  G4TessellatedSolid Inside: {str(ours.Inside(vec(*p))).split('.')[-1]}")
        print(f"  with 10^6 voxels: {str(fine.Inside(vec(*p))).split('.')[-1]}")
        print(f"  DistanceToIn: {ours.DistanceToIn(vec(*p)) * 1e6:.4g} nm")
        print(f"  Inside 100 nm either side: {', '.join(side)}")
        rng = np.random.default_rng(1)
        v = body.vertices
        rho_v = np.hypot(v[:, 0], v[:, 1])
        n = 3000
        rho = rng.uniform(rho_v.min(), rho_v.max(), n)
        zz = rng.uniform(v[:, 2].min(), v[:, 2].max(), n)
        phi = -layer.patch_size[0] / 2 / lay.radius[j] - rng.uniform(5e-5, 1e-3, n) / rho
        pts = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), zz])
        codes = [int(ours.Inside(vec(*q))) for q in pts]
        print(f"  {n} points 50-1000 nm outside its side wall: {codes.count(2)} called inside")


if __name__ == "__main__":
    main()
