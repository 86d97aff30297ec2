"""The area estimate of a boolean solid's faces: its error and its cost, one round of draws per
face (as before issue 24) against rounds until 0.1 % per face, and one face alone (on demand).

    .venv/bin/python benchmarks/bench_boolean_area.py [--repeat 3] [--live]

A 20 mm box less a 4 mm bore through it (exact area 2400 - 32 pi + 160 pi mm2): per setting the
estimated area, its standard error, the largest relative error of a face and the CPU time
(median of interleaved rounds; each round estimates anew, nothing kept from the one before). The
last line: the bore alone (``second.outer``) to 0.1 %, what a rough layer or a source on that
one face costs.

``--live``: a G4Torus (radii 5 and 20 mm, exact area 4 pi^2 100 mm2) read through the live solid
(``LiveSolidShape``, random lines in rounds of 10^5 until 0.1 %): its area, error, lines and CPU
time (one run, in Geant4).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import score4.shapes.boolean as B
from score4.shapes import G4Box, G4Tubs

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds")
    parser.add_argument("--live", action="store_true", help="the live-solid torus instead")
    args = parser.parse_args()
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
