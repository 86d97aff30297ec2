"""The area estimate of a boolean solid's faces: its error and its cost, one round of draws per
face (as before issue 24) against rounds until 0.1 % per face.

    .venv/bin/python benchmarks/bench_boolean_area.py [--repeat 3]

A 20 mm box less a 4 mm bore through it (exact area 2400 - 32 pi + 160 pi mm2): per setting the
estimated area, its standard error, the largest relative error of a face and the CPU time
(median of interleaved rounds).
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
    start = time.process_time()
    cut = B.BooleanShape("subtraction", G4Box(10, 10, 10), G4Tubs(0, 4, 20))
    area = cut.area
    cpu = time.process_time() - start
    errors = cut.face_area_errors
    total = math.sqrt(sum(e * e for e in errors.values()))
    worst = max(errors[f] / cut.face_areas[f] for f in cut.faces if cut.face_areas[f] > 0)
    return area, total, worst, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds")
    args = parser.parse_args()
    settings = {"one round (50 000 draws per face)": 1, "until 0.1 % per face": 40}
    runs: dict[str, list] = {k: [] for k in settings}
    for _ in range(args.repeat):
        for name, rounds in settings.items():
            runs[name].append(one(rounds))
    print(f"exact area {EXACT:.3f} mm2")
    for name, rows in runs.items():
        area, total, worst, _ = rows[0]
        cpu = float(np.median([r[3] for r in rows]))
        print(
            f"{name}: area {area:.3f} +- {total:.3f} mm2, worst face {100 * worst:.3f} %, "
            f"CPU {cpu:.2f} s (median of {len(rows)})"
        )


if __name__ == "__main__":
    main()
