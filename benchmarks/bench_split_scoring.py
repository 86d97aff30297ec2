"""Cost of ``output.split_by_particle`` (deposits split into alpha / electron / ion classes).

    .venv/bin/python benchmarks/bench_split_scoring.py [--events N] [--volumes K] [--po210]

5.3 MeV alphas (or Po-210 decays: alpha + 103 keV Pb-206 recoil, TRIM replay) from the top face
of the first of K silicon boxes stacked along z, lite physics, 1 um cut. Each setting runs in
its own process (one Geant4 application each) on the same events, best of three batches; the
two processes alternate ``--repeat`` times and the best of all counts (the machine is shared).
The split adds two filtered G4PSEnergyDeposit primitives per volume (C++ side, no Python per
step) and two more hits maps per volume for Python to read per event. Prints microseconds per
event with and without the split, the difference per volume, and the load.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import subprocess
import sys
import time

from score4.runner.run_plan import plan_run


def config(volumes: int, split: bool, po210: bool) -> dict:
    targets = [
        {
            "name": f"det_{k}",
            "size": ["2 mm", "2 mm", "0.5 mm"],
            "position": ["0 mm", "0 mm", f"{-0.25 - 0.6 * k} mm"],
        }
        for k in range(volumes)
    ]
    return {
        "physics": "lite",
        "targets": targets,
        "source": {
            **({"decay": "Po210"} if po210 else {"particle": "alpha", "energy": "5.3 MeV"}),
            "surface": {"volume": "det_0", "face": "+z"},
        },
        "output": {"split_by_particle": split},
    }


def measure(volumes: int, split: bool, n: int, po210: bool) -> dict:
    import numpy as np

    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    cfg = parse_config(config(volumes, split, po210))
    sim = Simulation(plan_run(cfg, physics=resolve_physics("lite")), log_path=None)
    primaries = sim.source.events(1, 0, n)
    sim.run(sim.source.events(1, n, 50), 7)  # warm-up: libraries, first-event costs
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        scores = sim.run(primaries, 11)
        best = min(best, time.perf_counter() - t0)
    return {
        "us_per_event": best / n * 1e6,
        "mean_edep_MeV": float(np.mean(scores["edep"][:, 0])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=2000)
    parser.add_argument("--volumes", type=int, default=2)
    parser.add_argument("--po210", action="store_true", help="Po-210 decays instead of alphas")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        split, n = args.child[0] == "split", int(args.child[1])
        print(json.dumps(measure(args.volumes, split, n, args.po210)))
        return
    rows: dict[str, dict] = {}
    for _, mode in itertools.product(range(args.repeat), ("plain", "split")):
        out = subprocess.run(
            [
                sys.executable,
                __file__,
                "--volumes",
                str(args.volumes),
                *(["--po210"] if args.po210 else []),
                "--child",
                mode,
                str(args.events),
            ],
            capture_output=True,
            text=True,
            check=True,
        )
        row = json.loads(out.stdout.strip().splitlines()[-1])
        if mode not in rows or row["us_per_event"] < rows[mode]["us_per_event"]:
            rows[mode] = row
    plain, split = rows["plain"]["us_per_event"], rows["split"]["us_per_event"]
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    what = "Po-210 decays" if args.po210 else "5.3 MeV alphas"
    print(f"{what} on Si, {args.volumes} volume(s), {args.events} events, best of {args.repeat}x3:")
    for mode in ("plain", "split"):
        row = rows[mode]
        print(
            f"  {mode:5s}  {row['us_per_event']:8.1f} us/event  "
            f"(mean edep det_0 {row['mean_edep_MeV']:.4f} MeV)"
        )
    per_volume = (split - plain) / args.volumes
    print(
        f"  cost   {split - plain:8.1f} us/event = {per_volume:.1f} us per volume per event "
        f"({(split / plain - 1) * 100:+.1f} %)"
    )


if __name__ == "__main__":
    main()
