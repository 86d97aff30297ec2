"""Where building a height-map patch's blocks in Geant4 spends its time and memory, per facet.

    .venv/bin/python benchmarks/bench_facet_handoff.py [--size 256] [--gdml]

One patch of a Gaussian random map of n x n pixels (0.5 um pitch, as bench_surfaces.py
--sizes), cut into closed blocks (score4.surface.block_cut). Each part runs in a fresh process
and prints its CPU seconds per facet (microseconds) and the growth of the process's resident
memory per facet (bytes), with the load:

``python``
    The way score4 hands the facets over (score4.geometry.block_solids.fast_tessellated): one
    ``G4ThreeVector`` per vertex, one ``G4TriangularFacet`` and one ``AddFacet`` call per facet,
    ``SetSolidClosed`` per block, each step timed on its own; the memory is the growth over the
    process after cutting the bodies.
``gdml`` (with ``--gdml``)
    The same blocks written as one GDML file (``<tessellated>`` solids, one ``<position>`` per
    vertex, a logical volume per block) and read by Geant4's ``G4GDMLParser`` in C++: writing
    the text, then reading it (Xerces and the GDML reader build every facet and close every
    solid). The vertices read back are checked equal, bit for bit, to the mesh's.

Geant4's own account of one block (``G4TessellatedSolid::AllocatedMemory``, which counts the
facets the solid keeps in its list of extreme facets twice) is printed too.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _rss() -> float:
    """Resident memory now, bytes."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _bodies(n: int):
    from score4.surface.block_cut import block_bodies
    from score4.surface.spec import build_surface

    spec = {"kind": "random", "nx": n + 1, "ny": n + 1, "pitch": "0.5 um", "sq": "0.3 um"}
    surface = build_surface({**spec, "corr_length": "3 um", "periodic": False, "seed": 1})
    return block_bodies(surface, 1e-3)


def child_python(n: int) -> None:
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    bodies = _bodies(n)
    facets = sum(b.n_faces for b in bodies)
    vec, facet, absolute = g4.G4ThreeVector, g4.G4TriangularFacet, g4.ABSOLUTE
    t = dict.fromkeys(("vectors", "facets", "AddFacet", "SetSolidClosed"), 0.0)
    keep = []
    r0 = _rss()
    for b, body in enumerate(bodies):
        c0 = time.process_time()
        solid = g4.G4TessellatedSolid(f"b{b}")
        points = [vec(*p) for p in body.vertices.tolist()]
        c1 = time.process_time()
        made = [facet(points[i], points[j], points[k], absolute) for i, j, k in body.faces.tolist()]
        c2 = time.process_time()
        for f in made:
            solid.AddFacet(f)
        c3 = time.process_time()
        solid.SetSolidClosed(True)
        c4 = time.process_time()
        for key, dt in zip(t, (c1 - c0, c2 - c1, c3 - c2, c4 - c3), strict=True):
            t[key] += dt
        keep.append(solid)
        del made, points
    grown = _rss() - r0
    per = " ".join(f"{k} {v / facets * 1e6:.2f}" for k, v in t.items())
    one = keep[0]
    print(
        f"python: {len(bodies)} blocks, {facets} facets; us per facet: {per}, total "
        f"{sum(t.values()) / facets * 1e6:.2f}; memory {grown / facets:.0f} bytes per facet "
        f"({grown / 1e6:.0f} MB); Geant4's account of block 0 ({bodies[0].n_faces} facets): "
        f"{one.AllocatedMemory()} bytes, {one.AllocatedMemoryWithoutVoxels()} without voxels"
    )


def child_gdml(n: int) -> None:
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    bodies = _bodies(n)
    facets = sum(b.n_faces for b in bodies)
    r0 = _rss()
    c0 = time.process_time()
    define, solids, volumes = [], [], []
    for b, body in enumerate(bodies):
        define += [
            f'<position name="b{b}v{i}" unit="mm" x="{x!r}" y="{y!r}" z="{z!r}"/>\n'
            for i, (x, y, z) in enumerate(body.vertices.tolist())
        ]
        solids.append(f'<tessellated name="b{b}" lunit="mm" aunit="rad">\n')
        solids += [
            f'<triangular vertex1="b{b}v{i}" vertex2="b{b}v{j}" vertex3="b{b}v{k}"/>\n'
            for i, j, k in body.faces.tolist()
        ]
        solids.append("</tessellated>\n")
        volumes.append(
            f'<volume name="L{b}"><materialref ref="G4_Si"/><solidref ref="b{b}"/></volume>\n'
        )
    text = "".join(
        [
            '<?xml version="1.0" encoding="UTF-8"?>\n<gdml>\n<define>\n',
            *define,
            "</define>\n<materials/>\n<solids>\n",
            *solids,
            '<box name="W" x="1" y="1" z="1" lunit="mm"/>\n</solids>\n<structure>\n',
            *volumes,
            '<volume name="W"><materialref ref="G4_Galactic"/><solidref ref="W"/></volume>\n',
            '</structure>\n<setup name="Default" version="1.0"><world ref="W"/></setup>\n</gdml>\n',
        ]
    )
    del define, solids, volumes
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "blocks.gdml"
        path.write_text(text)
        size = len(text)
        del text
        c1 = time.process_time()
        parser = g4.G4GDMLParser()
        parser.Read(str(path), False)
        c2 = time.process_time()
    lvs = [parser.GetVolume(f"L{b}") for b in range(len(bodies))]
    grown = _rss() - r0
    solid, body = lvs[-1].GetSolid(), bodies[-1]
    read = [
        (p.x, p.y, p.z)
        for k in range(solid.GetNumberOfFacets())
        for p in (solid.GetFacet(k).GetVertex(j) for j in range(3))
    ]
    equal = read == [tuple(p) for p in body.vertices[body.faces].reshape(-1, 3).tolist()]
    print(
        f"gdml: {len(bodies)} blocks, {facets} facets, {size / 1e6:.0f} MB of GDML; us per "
        f"facet: writing {(c1 - c0) / facets * 1e6:.2f}, reading {(c2 - c1) / facets * 1e6:.2f}; "
        f"memory {grown / facets:.0f} bytes per facet ({grown / 1e6:.0f} MB); "
        f"vertices read back equal: {equal}"
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=int, default=256, help="pixels per side of the map")
    p.add_argument("--gdml", action="store_true", help="also the GDML hand-off")
    p.add_argument("--child", choices=("python", "gdml"), help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        {"python": child_python, "gdml": child_gdml}[a.child](a.size)
        return
    print(f"load average at start: {os.getloadavg()}")
    for part in ("python", "gdml") if a.gdml else ("python",):
        cmd = [sys.executable, __file__, "--child", part, "--size", str(a.size)]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
        print(next(line for line in out.splitlines() if line.startswith(f"{part}:")))
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
