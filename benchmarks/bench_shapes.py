"""Sampling rates of score4.shapes per solid type (one core): surface points (all faces),
volume points, inside(), and vertices below all faces through VertexSampler.

Run: ``.venv/bin/python benchmarks/bench_shapes.py [--n 200000]``. Prints the load (``uptime``)
and, per solid, millions of points per second; the boolean's first call includes its area
estimate (printed separately). Not measured here: the live-solid path for other Geant4 solids
(random lines through geant4_pybind), which needs a Geant4 process.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import math
import subprocess
import time

import numpy as np

from score4.shapes import (
    BooleanShape,
    G4Box,
    G4Cons,
    G4GenericPolycone,
    G4Orb,
    G4Polycone,
    G4Polyhedra,
    G4Sphere,
    G4Trd,
    G4Tubs,
    Shape,
)
from score4.source.depth import VertexSampler
from score4.source.profiles import ExponentialProfile
from score4.source.shape_sampling import ShapeSurfaceSampler

ICPC_R = (0, 7, 7, 10, 10, 38, 40, 40, 35, 5, 5, 0)
ICPC_Z = (0, 0, 2, 2, 0, 0, 2, 75, 80, 80, 30, 30)


def solids() -> dict[str, Shape]:
    return {
        "G4Box": G4Box(10, 20, 30),
        "G4Trd": G4Trd(10, 5, 20, 8, 15),
        "G4Tubs (phi segment, bore)": G4Tubs(5, 35, 10, 0.3, 4.0),
        "G4Cons": G4Cons(2, 10, 5, 20, 15),
        "G4Sphere (all ranges)": G4Sphere(5, 10, 0.2, 2.0, 0.3, 1.0),
        "G4Orb": G4Orb(12),
        "G4Polycone (5 planes)": G4Polycone(
            0, 2 * math.pi, (0, 10, 10, 20, 30), (0, 0, 3, 5, 5), (10, 20, 15, 20, 20)
        ),
        "G4GenericPolycone (ICPC)": G4GenericPolycone(0, 2 * math.pi, ICPC_R, ICPC_Z),
        "G4Polyhedra (6 sides)": G4Polyhedra(
            0, 2 * math.pi, 6, (0, 10, 20), (0, 2, 2), (10, 12, 12)
        ),
        "box minus tube (boolean)": BooleanShape(
            "subtraction", G4Box(10, 10, 10), G4Tubs(0, 4, 20)
        ),
    }


def rate(fn, n: int) -> float:
    start = time.perf_counter()
    fn()
    return n / (time.perf_counter() - start) / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200_000)
    args = parser.parse_args()
    n = args.n
    print(subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip())
    print(f"{n} points per figure, Mpoints/s (one core)")
    print(f"{'solid':28s} {'surface':>8s} {'volume':>8s} {'inside':>8s} {'vertices':>9s}")
    rng = np.random.default_rng(1)
    for name, shape in solids().items():
        if isinstance(shape, BooleanShape):
            start = time.perf_counter()
            _ = shape.area
            print(f"  (boolean area estimate: {time.perf_counter() - start:.2f} s, once)")
        sampler = shape.face_sampler("all")
        surf = rate(lambda: sampler.sample(rng, n), n)  # noqa: B023  used at once
        vol = rate(lambda: shape.sample_volume(rng, n), n)  # noqa: B023
        lo, hi = shape.bounding_box()
        pts = lo + rng.random((n, 3)) * (hi - lo)
        ins = rate(lambda: shape.inside(pts), n)  # noqa: B023
        # a ShapeSurfaceSampler plugs in by its hook (as in score4.source.build)
        surface = ShapeSurfaceSampler(shape, "all")
        vs = VertexSampler(surface, ExponentialProfile(20e-6))  # type: ignore[arg-type]
        vtx = rate(lambda: vs.sample(rng, n), n)  # noqa: B023
        print(f"{name:28s} {surf:8.2f} {vol:8.2f} {ins:8.2f} {vtx:9.2f}")


if __name__ == "__main__":
    main()
