"""Geantinos exactly (to the bit) on block corners, in block cut planes and in patch-cell walls.

    .venv/bin/python benchmarks/bench_block_corners.py [--cases a,b]

The +z face (0.2 mm x 0.2 mm) of a silicon box holds 2 x 2 patches. Rays: straight down and
slanted through every inner block corner of one patch, straight down through the face centre
(the corner of the 4 patch cells: a pencil beam along the normal), and horizontal rays lying in
block cut planes and in the patch-cell wall, inside the rough layer and in the slab under it.
Each ray's track length in the crystal (``output: track_length``) is compared with the path
along the exact mesh: the mesh height + slab + box for straight-down rays, the fraction of
points inside the body sampled every 0.5 nm for the others (so errors below ~1e-6 mm are the
sampling's). Printed per ray class: rays, rays off by more than 1e-6 mm, the largest error, and
from Geant4's log the tracks pushed (GeomNav1002) and killed with their event (GeomNav0003).
Cases: ``random_tess``/``random_blocks`` (a 40 x 40-pixel random map as one tessellated solid or
as auto blocks of 2 x 2 pixels), ``pyramids_union``/``pyramids_blocks`` (10 x 10 equal pyramids
as the paper's multi-union, or blocks of 2 x 2 spikes).

``--union-sizes 40,64,90,128``: instead, the cost of the candidate fix "one G4MultiUnion of a
patch's blocks" (shared walls inside one solid): build and voxelise a multi-union of the auto
blocks (2 x 2 pixels) of an n x n-pixel random map (0.5 um pitch) in this process; CPU seconds
and the process's peak RSS, one size per process (``--union-sizes 90``) for a clean RSS.

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_block_corners.py.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.source.primaries import Primaries
from score4.source.vertex_file import write_vertex_file
from score4.surface import block_cut as blk
from score4.world.resolve import build_scene

RANDOM = {
    "kind": "random",
    "nx": 40,
    "ny": 40,
    "pitch": "2.5 um",
    "sq": "1 um",
    "corr_length": "8 um",
    "seed": 2,
}
PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
CASES = {
    "random_tess": (RANDOM, "tessellated", None),
    "random_blocks": (RANDOM, "blocks", None),
    "pyramids_union": (PYRAMIDS, "multiunion", None),
    "pyramids_blocks": (PYRAMIDS, "blocks", 2),
}
BOX_Z = 0.1  # mm


def config_data(surface: dict, solid: str, cells: int | None) -> dict:
    rough: dict[str, str | int] = {"face": "+z", "surface": "s", "solid": solid}
    if cells:
        rough["block_cells"] = cells
    return {
        "physics": "lite",
        "surfaces": {"s": surface},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["0.2 mm", "0.2 mm", f"{BOX_Z} mm"],
                "position": ["0 mm", "0 mm", f"{-BOX_Z / 2} mm"],
                "rough": [rough],
            }
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "crystal", "face": "+z"},
        },
    }


def rays(layer, cells: int | None):
    """(positions, directions, class of each ray)."""
    lu, lv = layer.frame.size
    top = layer.thickness + 1e-4
    s = layer.variants[0]
    ny, nx = blk.cell_shape(s)
    auto = blk.auto_block_cells(s)
    ex, ey = blk.block_edges(nx, cells, "x", auto), blk.block_edges(ny, cells, "y", auto)
    c = layer.cell_centres()[0, 0]
    bx = (c[0] - s.size_x / 2 + ex * (s.size_x / nx))[1:-1]
    by = (c[1] - s.size_y / 2 + ey * (s.size_y / ny))[1:-1]
    gx, gy = (a.ravel() for a in np.meshgrid(bx, by))
    out: list[tuple] = []
    out += [((x, y, top), (0, 0, -1), "block corner, down") for x, y in zip(gx, gy, strict=True)]
    out += [
        ((x, y, top), (1, 0.9, -0.5), "block corner, slanted") for x, y in zip(gx, gy, strict=True)
    ][:40]
    out.append(((0.0, 0.0, top), (0, 0, -1), "face centre, down"))
    zs = {
        "rough layer": layer.base_thickness + 0.3 * (layer.thickness - layer.base_thickness),
        "slab": layer.base_thickness / 2,
    }
    for where, z in zs.items():
        out += [((-lu / 2 + 1e-4, y, z), (1, 0, 0), f"cut plane y, {where}") for y in by]
        out += [((x, -lv / 2 + 1e-4, z), (0, 1, 0), f"cut plane x, {where}") for x in bx]
        out.append(((-lu / 2 + 1e-4, 0.0, z), (1, 0, 0), f"patch wall, {where}"))
    pos = np.array([p for p, _, _ in out], float)
    d = np.array([d for _, d, _ in out], float)
    return pos, d / np.linalg.norm(d, axis=1)[:, None], np.array([t for _, _, t in out])


def reference(scene, layer, pos, d) -> np.ndarray:
    """Path in the crystal along the exact mesh."""
    ref = np.empty(len(pos))
    down = (d == [0, 0, -1.0]).all(axis=1)
    i, j = layer.patch_map.cell_of(pos[down, :2])
    c = layer.cell_centres()[j, i]
    h = layer.variants[0].height_at(pos[down, 0] - c[:, 0], pos[down, 1] - c[:, 1])
    ref[down] = h + layer.base_thickness + BOX_Z
    t = np.linspace(0.0, 0.6, 1_200_001)
    for k in np.flatnonzero(~down):
        ref[k] = scene.inside_target("crystal", pos[k] + t[:, None] * d[k]).mean() * 0.6
    return ref


def measure(name: str) -> None:
    surface, solid, cells = CASES[name]
    data = config_data(surface, solid, cells)
    config = parse_config(data)
    scene = build_scene(config)
    layer = scene.layers[0]
    pos, d, tags = rays(layer, cells)
    n = len(pos)
    tmp = Path(tempfile.mkdtemp())
    prim = Primaries(
        event=np.arange(n),
        particle=np.full(n, "geantino"),
        energy=np.ones(n),
        position=pos,
        direction=d,
    )
    vfile = write_vertex_file(tmp / "v.h5", prim, {}, 1)
    replay = {
        **data,
        "source": {"vertices": str(vfile)},
        "output": {"track_length": True},
        "run": {"events": n, "seed": 5},
    }
    out = run(parse_config(replay), tmp / "o.h5", progress=False, echo=lambda m: None)
    res = read_results(out)
    path = res.scores["track_length"]["crystal"]
    err = path - reference(scene, layer, pos, d)
    print(
        f"{name}: Geant4 pushed {res.run['stuck_tracks_pushed']} stuck tracks, killed "
        f"{res.run['stuck_events_aborted']} (events aborted)"
    )
    print(f"    {'rays':28s} {'n':>4s} {'off>1e-6mm':>10s} {'max |err| mm':>13s}")
    for tag in dict.fromkeys(tags):
        m = tags == tag
        bad = int((np.abs(err[m]) > 1e-6).sum())
        print(f"    {tag:28s} {m.sum():4d} {bad:10d} {np.abs(err[m]).max():13.3g}")


def union_cost(n: int) -> None:
    """Build + voxelise one G4MultiUnion of the blocks of an n x n-pixel random map."""
    import resource
    import time

    from score4.geometry.block_solids import fast_tessellated
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.spec import build_surface

    g4 = import_geant4(resolve_physics("lite"))
    spec = {**RANDOM, "nx": n, "ny": n, "pitch": "0.5 um", "corr_length": "2 um"}
    bodies = blk.block_bodies(build_surface(spec), 1e-3)
    t0 = time.process_time()
    solids = [fast_tessellated(g4, b, f"b{i}") for i, b in enumerate(bodies)]
    union, where = g4.G4MultiUnion("patch"), g4.G4Transform3D()
    for solid in solids:
        union.AddNode(solid, where)
    t1 = time.process_time()
    union.Voxelize()
    t2 = time.process_time()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(
        f"{n} x {n} px: {len(bodies)} blocks, build {t1 - t0:.2f} s, voxelise {t2 - t1:.2f} s, "
        f"peak RSS {rss:.0f} MB"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--union-sizes", default="")
    args = parser.parse_args()
    if args.union_sizes:
        for n in args.union_sizes.split(","):
            union_cost(int(n))
        return
    for name in args.cases.split(","):
        measure(name)
        sys.stdout.flush()


if __name__ == "__main__":
    import warnings

    warnings.simplefilter("ignore")  # the run warns about these rays: that is the point here
    main()
