"""Geant4's own memory and CPU per G4TriangularFacet and per G4TessellatedSolid in this
geant4_pybind build: the floor under any patch that hands Geant4 one facet per map triangle.

    .venv/bin/python benchmarks/g4_facet_memory.py [--solids 2000] [--facets 22,166]

Each row runs in a fresh process: it makes ``--solids`` copies of one closed block as score4
cuts it (``block_cut.block_body`` of an n x n-pixel piece of a random map; ``--facets`` picks n
by the block's facets: 22 for 2 x 2 pixels, 36 for 3 x 3, 54 for 4 x 4, 166 for 8 x 8, the
blocks of a 1024 x 1024 exact map) and hands them to Geant4 as ``place_blocks`` does, step by
step, reading the C heap's bytes in use (glibc ``mallinfo2``: ``uordblks + hblkhd``, exact to
the byte, no page rounding, freed memory not counted) and the CPU time after each step:

``empty solid``  ``G4TessellatedSolid(name)`` alone (the object and its empty containers);
``facets``       one ``G4ThreeVector`` per vertex, one ``G4TriangularFacet`` and one ``AddFacet``
                 per facet, before closing;
``closed``       ``SetSolidClosed(True)`` with the row's voxels (Geant4's own choice,
                 ``SetMaxVoxels(8)``, or ``SetMaxVoxels(0)``: none); closing also replaces each
                 facet's own three vertices by indices into one vertex list of the solid;
``volumes``      a ``G4LogicalVolume`` and a ``G4PVPlacement`` per block, and a ``G4Box`` floor
                 with its own logical and physical volume (what ``place_blocks`` adds).

Figures: bytes per solid and per facet (the step's growth over the solids, over all facets),
CPU microseconds per facet. Python's small objects live in pymalloc's arenas, outside that
count: ``Python blocks per solid`` is the growth of ``sys.getallocatedblocks()`` over the step,
to show whether the binding keeps a Python object per facet alive (0: it does not).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import subprocess
import sys

ROWS = {"default": -1, "8 voxels": 8, "no voxels": 0}


class _Mallinfo2(ctypes.Structure):
    _fields_ = [
        (name, ctypes.c_size_t)
        for name in (
            "arena",
            "ordblks",
            "smblks",
            "hblks",
            "hblkhd",
            "usmblks",
            "fsmblks",
            "uordblks",
            "fordblks",
            "keepcost",
        )
    ]


def heap_in_use() -> int:
    """Bytes of the C heap in use (small and large allocations), now."""
    libc = ctypes.CDLL("libc.so.6")
    libc.mallinfo2.restype = _Mallinfo2
    info = libc.mallinfo2()
    return int(info.uordblks + info.hblkhd)


def _block(facets: int):
    """(vertices, faces) of one closed block of about ``facets`` facets, as score4 cuts it."""
    from score4.surface.block_cut import block_body, split_top
    from score4.surface.spec import build_surface

    n = {22: 2, 36: 3, 54: 4, 166: 8}.get(facets)
    if n is None:
        raise SystemExit(f"--facets: {facets} is not one of 22, 36, 54, 166")
    spec = {"kind": "random", "nx": 8 * n + 1, "ny": 8 * n + 1, "pitch": "0.5 um", "sq": "0.3 um"}
    surface = build_surface({**spec, "corr_length": "1 um", "periodic": False, "seed": 1})
    top = split_top(surface, n)[5]
    body = block_body(top, 1e-3)
    return body.vertices, body.faces.tolist()


def child(n_solids: int, facets: int, voxels: int) -> None:
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    vertices, faces = _block(facets)
    mat = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Si")
    mother = g4.G4LogicalVolume(g4.G4Box("m", 1.0, 1.0, 1.0), mat, "m")
    vec, facet, absolute = g4.G4ThreeVector, g4.G4TriangularFacet, g4.ABSOLUTE
    rows = vertices.tolist()
    keep: list = []
    steps = {}
    import time

    t0 = time.process_time()
    h0, p0 = heap_in_use(), sys.getallocatedblocks()
    solids = [g4.G4TessellatedSolid(f"b{i}") for i in range(n_solids)]
    h1, p1, t1 = heap_in_use(), sys.getallocatedblocks(), time.process_time()
    steps["empty solid"] = (h1 - h0, p1 - p0, t1 - t0)
    for solid in solids:
        points = [vec(*p) for p in rows]
        for a, b, c in faces:
            solid.AddFacet(facet(points[a], points[b], points[c], absolute))
        del points
    h2, p2, t2 = heap_in_use(), sys.getallocatedblocks(), time.process_time()
    steps["facets"] = (h2 - h1, p2 - p1, t2 - t1)
    for solid in solids:
        if voxels >= 0:
            solid.SetMaxVoxels(voxels)
        solid.SetSolidClosed(True)
    h3, p3, t3 = heap_in_use(), sys.getallocatedblocks(), time.process_time()
    steps["closed"] = (h3 - h2, p3 - p2, t3 - t2)
    where = vec(0.0, 0.0, 0.0)
    for i, solid in enumerate(solids):
        lv = g4.G4LogicalVolume(solid, mat, f"b{i}")
        pv = g4.G4PVPlacement(None, where, lv, f"b{i}", mother, False, i, False)
        box = g4.G4Box(f"f{i}", 1e-3, 1e-3, 1e-3)
        flv = g4.G4LogicalVolume(box, mat, f"f{i}")
        at = vec(0.0, 0.0, 0.0)
        fpv = g4.G4PVPlacement(None, at, flv, f"f{i}", mother, False, i, False)
        keep += [lv, pv, box, flv, fpv, at]
    h4, p4, t4 = heap_in_use(), sys.getallocatedblocks(), time.process_time()
    steps["volumes"] = (h4 - h3, p4 - p3, t4 - t3)
    n_facets = n_solids * len(faces)
    for name, (heap, py, cpu) in steps.items():
        print(
            f"{name}\t{heap / n_solids:.0f}\t{heap / n_facets:.1f}\t{py / n_solids:.1f}"
            f"\t{cpu / n_facets * 1e6:.2f}"
        )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--solids", type=int, default=2000)
    p.add_argument("--facets", default="22,166")
    p.add_argument("--child", nargs=3, type=int, help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(*a.child)
        return
    print(f"load {os.getloadavg()[0]:.1f}; {a.solids} solids per row; C heap bytes (mallinfo2)")
    print(
        "| facets a block | voxels | step | bytes per solid | bytes per facet "
        "| Python blocks per solid | CPU us per facet |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for facets in map(int, a.facets.split(",")):
        for label, voxels in ROWS.items():
            cmd = [sys.executable, __file__, "--child", str(a.solids), str(facets), str(voxels)]
            out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
            for line in out.splitlines():
                if line.count("\t") != 4:
                    continue
                step, per_solid, per_facet, py, us = line.split("\t")
                print(f"| {facets} | {label} | {step} | {per_solid} | {per_facet} | {py} | {us} |")


if __name__ == "__main__":
    main()
