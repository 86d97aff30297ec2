"""The cost of measuring steps to a rough surface (``targets[].activeness`` and ``dist_to_surf`` on
a face with a flat rough layer, :mod:`score4.world.rough_distance`).

    python benchmarks/bench_rough_distance.py [--events 1000] [--rounds 3]

Po-210 alphas (5.3 MeV, isotropic) from the tops of 10 um pyramids (0.5 mm patches of 50 x 50,
1 um base) on the +z face of a germanium box, lite physics, steps recorded. Per round, in this
process: the CPU time of tracking the events (steps recorded), then, on the same steps, of the
distances to the rough face (k-d tree search, first use excluded) and to the flat face (the
plane, as before). Medians over interleaved rounds; the figures per step and per event, and the
rough distance's share of the run.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from stamp import stamp


def config(events: int) -> dict:
    return {
        "physics": "lite",
        "surfaces": {
            "pyramids": {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
        },
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Ge",
                "size": ["10 mm", "10 mm", "10 mm"],
                "rough": [{"face": "+z", "surface": "pyramids", "base_thickness": "1 um"}],
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
        },
        "run": {"events": events, "seed": 3},
        "output": {"steps": True},
    }


def main() -> None:
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation
    from score4.world.face_distance import face_distance

    ap = argparse.ArgumentParser()
    ap.add_argument("--events", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    print(stamp())
    sim = Simulation(plan_run(parse_config(config(args.events)), physics=resolve_physics("lite")))
    assert sim.distances is not None
    distance = sim.distances[0]
    assert distance is not None
    target = distance.target
    rough = distance.rough_distance("+z")
    rough(np.zeros((1, 3)))  # the first use builds the k-d trees
    run_t, rough_t, flat_t, n_steps = [], [], [], []
    for r in range(args.rounds):
        first = (r + 1) * args.events
        primaries = sim.source.events(3, first, args.events)
        c0 = time.process_time()
        sim.run(primaries, event_geant4_seeds(3, first, args.events))
        run_t.append(time.process_time() - c0)
        assert sim.last_steps is not None
        s = sim.last_steps
        points = np.column_stack([s["x"], s["y"], s["z"]])
        n_steps.append(len(points))
        c0 = time.process_time()
        rough(points)
        rough_t.append(time.process_time() - c0)
        c0 = time.process_time()
        face_distance(target.shape, ("+z",), target.to_local(points))
        flat_t.append(time.process_time() - c0)
    n = statistics.median(n_steps)
    run, ro, fl = (statistics.median(x) for x in (run_t, rough_t, flat_t))
    inside = float(np.mean(distance.rough["+z"][0].contains(points)))
    print(f"{args.events} events x {args.rounds} interleaved rounds, {n / args.events:.0f} steps")
    print(f"with deposit per event, {100 * inside:.0f} % of them inside the pyramids (CPU medians)")
    print(f"tracking with steps: {run / args.events * 1e6:.0f} us per event")
    print(
        f"rough distance: {ro / n * 1e6:.2f} us per step, {ro / args.events * 1e6:.0f} us per "
        f"event, {100 * ro / run:.1f} % of the run"
    )
    print(f"flat distance: {fl / n * 1e6:.2f} us per step, rough/flat x{ro / fl:.1f}")


if __name__ == "__main__":
    main()
