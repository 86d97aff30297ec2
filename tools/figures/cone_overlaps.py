"""Geant4's overlap check of bent tessellated patches on a G4Cons face, and why it was wrong.

    .venv/bin/python tools/figures/cone_overlaps.py

Writes a small G4Cons (radius 3 -> 4 mm over 0.6 mm, 0.3 rad of phi) with 10 um pyramids on its
``outer`` face (``solid: tessellated``), runs ``score4 geometry check`` on it (Geant4's
CheckOverlaps on every bent patch, 1000 points each; each report between two tessellated bodies
re-tested exactly) and prints its summary. Then, for ring 1's body, the largest distance beyond
a facet's edge that ``G4TriangularFacet::Intersect`` accepts (``intersect_tolerance``) with the
floor as a strip between its long edges (score4 before issue 24's fix) and as Geant4 gets it
now, and how many of 3000 points 3-30 nm outside its walls and floor (exactly outside, by more
than 2 nm) ``G4TessellatedSolid::Inside`` calls inside, for both.
Checked by docs/geometry.md (check ``cone-overlaps``).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml

from score4.inputs.config import load_config
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer


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


def main() -> None:
    argparse.ArgumentParser(description=__doc__.split("\n")[0]).parse_args()
    from score4.geometry.solids import tessellated_solid
    from score4.shapes.mesh_shape import MeshShape
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.triangle_mesh import TriangleMesh, intersect_tolerance

    with tempfile.TemporaryDirectory() as tmp:
        cfg = write_cone(Path(tmp))
        check = subprocess.run(
            [sys.executable, "-m", "score4", "geometry", "check", cfg.name],
            cwd=tmp,
            capture_output=True,
            text=True,
        )
        scene = build_scene(load_config(cfg))
    for line in check.stdout.splitlines():
        if not line.startswith("  cone_rough"):  # the per-layer progress line
            print(line)
    layer = scene.layers[0]
    assert isinstance(layer, CurvedRoughLayer)
    lay, j = layer.ring_layout, 1
    v0, f0, n_top = layer._flat(0)
    strip = lay.bend(v0, j, layer.base_thickness + layer.lift)
    built = layer.bent(0, j)
    bodies = {"strip floor": (strip, f0), "as built": (built.vertices, built.faces)}
    # probe points off the strip body's walls and floor (the same surface as built)
    rng = np.random.default_rng(1)
    tri = strip[f0]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    n = 3000
    pick = rng.integers(n_top, len(f0), n)
    r1, r2 = rng.random(n), rng.random(n)
    over = r1 + r2 > 1
    r1[over], r2[over] = 1 - r1[over], 1 - r2[over]
    out = normal[pick] + 0.3 * rng.normal(size=(n, 3))
    out /= np.linalg.norm(out, axis=1)[:, None]
    t = tri[pick]
    pts = t[:, 0] + r1[:, None] * (t[:, 1] - t[:, 0]) + r2[:, None] * (t[:, 2] - t[:, 0])
    pts += rng.uniform(3e-6, 30e-6, n)[:, None] * out
    pts = pts[MeshShape(tri).signed_distance(pts) > 2e-6]
    g4 = import_geant4(resolve_physics("lite"))
    vec = g4.G4ThreeVector
    print(f"ring {j}'s body; {len(pts)} points 3-30 nm outside its walls and floor:")
    for name, (v, f) in bodies.items():
        solid = tessellated_solid(g4, TriangleMesh(v, f), name.replace(" ", "_"))
        wrong = sum(solid.Inside(vec(*q)) == g4.EInside.kInside for q in pts)
        tol = float(intersect_tolerance(v[f]).max()) * 1e6
        print(
            f"  {name}: {len(f)} facets, Intersect accepts up to {tol:.3g} nm beyond an edge; "
            f"Inside calls {wrong} of them inside"
        )


if __name__ == "__main__":
    main()
