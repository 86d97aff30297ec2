"""The cost of recording steps (``output.steps``, ``targets[].activeness``): a Python stepping
action called for every step.

    python benchmarks/bench_steps.py [--events 2000] [--rounds 3]

5.3 MeV alphas at normal incidence into a germanium box (lite physics, 1 um cut), tracked in
this process by one :class:`score4.sim.simulation.Simulation` per setting: steps off, steps on,
steps with activeness (a 5 um dead layer on every face). Rounds are interleaved; the table gives
the median CPU time per event of each and the ratio to steps off, and the steps per event.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np


def config(steps: bool, activeness: bool) -> dict:
    return {
        "physics": "lite",
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Ge",
                "size": ["10 mm", "10 mm", "10 mm"],
                "activeness": [{"fccd": "5 um", "dlf": 1.0}] if activeness else [],
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "normal",
            "surface": {"volume": "crystal", "face": "+z"},
        },
        "run": {"events": 1000, "seed": 3},
        "output": {"steps": steps},
    }


_SIM = None


def _setup(steps: bool, activeness: bool) -> None:
    global _SIM
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    plan = plan_run(parse_config(config(steps, activeness)), physics=resolve_physics("lite"))
    _SIM = Simulation(plan)


def _round(first: int, n: int) -> tuple[float, float]:
    from score4.runner.seeds import event_geant4_seeds

    sim = _SIM
    assert sim is not None
    primaries = sim.source.events(3, first, n)
    c0 = time.process_time()
    sim.run(primaries, event_geant4_seeds(3, first, n))
    cpu = (time.process_time() - c0) / n
    steps = np.nan if sim.last_steps is None else len(sim.last_steps["edep"]) / n
    return cpu, steps


def main() -> None:
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    ap = argparse.ArgumentParser()
    ap.add_argument("--events", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    with open("/proc/loadavg") as f:
        print(f"load at start: {f.read().split()[0]}")
    cases = {
        "steps off": (False, False),
        "steps on": (True, False),
        "activeness": (False, True),
    }
    ctx = mp.get_context("spawn")
    pools = {
        name: ProcessPoolExecutor(1, mp_context=ctx, initializer=_setup, initargs=flags)
        for name, flags in cases.items()
    }
    times: dict[str, list[float]] = {name: [] for name in cases}
    n_steps: dict[str, float] = {}
    try:
        for pool in pools.values():  # build each application before timing
            pool.submit(_round, 0, 10).result()
        for r in range(args.rounds):
            for name, pool in pools.items():
                cpu, steps = pool.submit(_round, (r + 1) * args.events, args.events).result()
                times[name].append(cpu)
                n_steps[name] = steps
    finally:
        for pool in pools.values():
            pool.shutdown()
    base = statistics.median(times["steps off"])
    print(f"{args.events} events x {args.rounds} interleaved rounds, CPU time per event (median)")
    for name in cases:
        t = statistics.median(times[name])
        extra = (
            f", {n_steps[name]:.0f} steps with deposit per event"
            if not np.isnan(n_steps[name])
            else ""
        )
        print(f"  {name:11s} {t * 1e6:8.0f} us  x{t / base:.2f}{extra}")


if __name__ == "__main__":
    main()
