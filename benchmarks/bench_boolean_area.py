"""The area estimate of a boolean solid's faces: its error and its cost, one round of draws per
face (as before issue 24) against rounds until 0.1 % per face, and one face alone (on demand).

    .venv/bin/python benchmarks/bench_boolean_area.py [--repeat 3] [--live | --mesh [--rounds 1]]

A 20 mm box less a 4 mm bore through it (exact area 2400 - 32 pi + 160 pi mm2): per setting the
estimated area, its standard error, the largest relative error of a face and the CPU time
(median of interleaved rounds; each round estimates anew, nothing kept from the one before). The
last line: the bore alone (``second.outer``) to 0.1 %, what a rough layer or a source on that
one face costs.

``--live``: a G4Torus (radii 5 and 20 mm, exact area 4 pi^2 100 mm2) read through the live solid
(``LiveSolidShape``, random lines in rounds of 10^5 until 0.1 %): its area, error, lines and CPU
time (one run, in Geant4).

``--mesh``: a 20 mm box less an extruded L-shaped pocket and less a tessellated frustum (meshes,
``MeshShape``), each hole grown by 20 um on one face, as in tests/test_into_subtracted_meshes.py:
the CPU time of all their face areas (``--rounds`` rounds of draws at most per face, nothing kept
between rounds) with each constituent's signed distance measured against every facet with
winding numbers (as before issue 25) and as now (the facets that can be nearest, the side from
the nearest facet), interleaved; the same areas either way (checked); and the CPU time per
point of ``MeshShape.signed_distance`` on 400 000 points 0.1 um either side of the pocket's faces.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from typing import Any

import numpy as np

import score4.shapes.boolean as B
from score4.shapes import G4Box, G4Tubs, MeshShape
from score4.shapes.transform import Transform

EXACT = 2400 - 2 * math.pi * 16 + 2 * math.pi * 4 * 20


def one(rounds: int) -> tuple[float, float, float, float]:
    B.MAX_AREA_ROUNDS = rounds
    B._AREAS.clear()  # estimated anew, not read from the round before
    start = time.process_time()
    cut = B.BooleanShape("subtraction", G4Box(10, 10, 10), G4Tubs(0, 4, 20))
    area = cut.area
    cpu = time.process_time() - start
    errors = cut.face_area_errors
    total = math.sqrt(sum(e * e for e in errors.values()))
    worst = max(errors[f] / cut.face_areas[f] for f in cut.faces if cut.face_areas[f] > 0)
    return area, total, worst, cpu


def bore() -> tuple[float, float, float]:
    """The bore's area alone, to 0.1 %: (area, error, CPU seconds)."""
    B.MAX_AREA_ROUNDS = 40
    B._AREAS.clear()
    start = time.process_time()
    cut = B.BooleanShape("subtraction", G4Box(10, 10, 10), G4Tubs(0, 4, 20))
    area = cut.face_areas["second.outer"]
    cpu = time.process_time() - start
    return area, cut.face_area_errors["second.outer"], cpu


def live() -> None:
    from score4.geometry.solid_shapes import LiveSolidShape
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    torus = g4.G4Torus("torus", 0, 5, 20, 0, 2 * math.pi)
    for cap in (100_000, 4_000_000):
        start = time.process_time()
        shape = LiveSolidShape(torus, max_area_lines=cap)
        area, err = shape.area, shape.area_error
        cpu = time.process_time() - start
        print(
            f"live torus, at most {cap} lines: area {area:.2f} +- {err:.2f} mm2 "
            f"({100 * err / area:.3f} %), exact {4 * math.pi**2 * 100:.2f}, CPU {cpu:.1f} s"
        )


def meshes() -> dict[str, Any]:
    """The grown pocket and frustum of tests/test_into_subtracted_meshes.py, as meshes."""
    outline = [(-2.5, -2.0), (2.5, -2.0), (2.0, 0.5), (0.3, 0.8), (0.0, 2.2), (-2.5, 2.0)]
    lo = [np.array([x, y, -5.0]) for x, y in outline]
    hi = [np.array([x, y, 5.0]) for x, y in outline]
    m = len(outline)
    tris = []
    for a in range(m):
        b = (a + 1) % m
        tris += [[lo[a], lo[b], hi[b]], [lo[a], hi[b], hi[a]]]
    for i in range(4, 8):  # ends: a fan from the reflex corner (3), which sees the others
        j, k = i % m, (i + 1) % m
        tris += [[hi[3], hi[j], hi[k]], [lo[3], lo[k], lo[j]]]
    pocket = MeshShape.by_planes(np.array(tris), extruded=True).moved({"side_2": -0.02})
    verts = np.array([[2, -2, -5], [2, 2, -5], [-2, 2, -5], [-2, -2, -5], [3, -3, 5], [3, 3, 5],
                      [-3, 3, 5], [-3, -3, 5], [0, 0, -5], [2, 0, -5]], float)  # fmt: skip
    faces = [[8, 9, 0], [8, 1, 9], [8, 2, 1], [8, 3, 2], [8, 0, 3], [0, 9, 4], [9, 5, 4],
             [9, 1, 5], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7],
             [4, 5, 6], [4, 6, 7]]  # fmt: skip
    frustum = MeshShape.by_planes(verts[np.array(faces)]).moved({"plane_0": -0.02})
    assert pocket is not None
    assert frustum is not None
    return {"pocket": pocket[0], "frustum": frustum[0]}


def mesh_areas(rounds: int, every_facet: bool) -> tuple[dict[str, float], float]:
    """All face areas of the box less each mesh, and the CPU seconds they took."""
    B.MAX_AREA_ROUNDS = rounds
    B._AREAS.clear()
    saved = MeshShape.__dict__["_search"]
    if every_facet:
        MeshShape._search = property(lambda self: None)  # type: ignore[assignment,method-assign]
    try:
        start = time.process_time()
        areas = {}
        for name, mesh in meshes().items():
            cut = B.BooleanShape(
                "subtraction",
                G4Box(10, 10, 10),
                mesh,
                Transform(translation=np.array([0, 0, 10.0])),
            )
            areas.update({f"{name} {f}": a for f, a in cut.face_areas.items()})
        return areas, time.process_time() - start
    finally:
        MeshShape._search = saved  # type: ignore[method-assign]


def mesh(repeat: int, rounds: int) -> None:
    print(f"load {os.getloadavg()[0]:.2f}")
    cpu: dict[bool, list[float]] = {True: [], False: []}
    found: dict[bool, dict[str, float]] = {}
    for _ in range(repeat):
        for every in (True, False):
            found[every], seconds = mesh_areas(rounds, every)
            cpu[every].append(seconds)
    same = found[True] == found[False]
    for every, label in ((True, "every facet, winding numbers"), (False, "nearest facets")):
        print(
            f"box less pocket and frustum, all {len(found[every])} face areas, at most {rounds} "
            f"rounds: {label}: CPU {np.median(cpu[every]):.2f} s (median of {repeat})"
        )
    print(f"ratio {np.median(cpu[True]) / np.median(cpu[False]):.1f}x; same areas: {same}")
    pocket = meshes()["pocket"]
    rng = np.random.default_rng(1)
    s = pocket.sample_surface(rng, 200_000)
    p = np.concatenate([s.position + 1e-4 * s.normal, s.position - 1e-4 * s.normal])
    per: dict[bool, list[float]] = {True: [], False: []}
    values = {}
    for _ in range(repeat):
        for every in (True, False):
            shape = MeshShape(pocket.triangles)
            if every:
                shape.__dict__["_search"] = None  # the cached search: none, every facet
            start = time.process_time()
            values[every] = shape.signed_distance(p)
            per[every].append((time.process_time() - start) / len(p))
    print(
        f"pocket signed distance, {len(p)} points 0.1 um off its faces: every facet "
        f"{1e6 * np.median(per[True]):.2f} us, nearest facets {1e6 * np.median(per[False]):.2f} "
        f"us per point (median of {repeat}); same numbers: "
        f"{np.array_equal(values[True], values[False])}"
    )
    print(f"load {os.getloadavg()[0]:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds")
    parser.add_argument("--live", action="store_true", help="the live-solid torus instead")
    parser.add_argument("--mesh", action="store_true", help="boxes less meshes instead")
    parser.add_argument("--rounds", type=int, default=1, help="--mesh: most rounds per face")
    args = parser.parse_args()
    if args.mesh:
        mesh(args.repeat, args.rounds)
        return
    if args.live:
        live()
        return
    settings = {"one round (50 000 draws per face)": 1, "until 0.1 % per face": 40}
    runs: dict[str, list] = {k: [] for k in settings}
    alone = []
    for _ in range(args.repeat):
        for name, rounds in settings.items():
            runs[name].append(one(rounds))
        alone.append(bore())
    print(f"exact area {EXACT:.3f} mm2")
    for name, rows in runs.items():
        area, total, worst, _ = rows[0]
        cpu = float(np.median([r[3] for r in rows]))
        print(
            f"{name}: area {area:.3f} +- {total:.3f} mm2, worst face {100 * worst:.3f} %, "
            f"CPU {cpu:.2f} s (median of {len(rows)})"
        )
    area, err, _ = alone[0]
    cpu = float(np.median([r[2] for r in alone]))
    print(
        f"the bore alone (second.outer), until 0.1 %: area {area:.3f} +- {err:.3f} mm2 "
        f"(exact {2 * math.pi * 4 * 20:.3f}), CPU {cpu:.2f} s (median of {len(alone)})"
    )


if __name__ == "__main__":
    main()
