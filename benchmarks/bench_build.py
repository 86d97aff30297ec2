"""Building large rough faces and patches: CPU seconds and peak memory, and the CPU per alpha event.

    .venv/bin/python benchmarks/bench_build.py [--cases face1m2,face10m2,spikes50,spikes1000]
        [--repeat 3] [--events 1000]

Each case builds a whole ``Simulation`` (the run plan: scene, source; then the Geant4 geometry
and physics) in a fresh process and prints the CPU seconds of that build, the process's peak RSS,
and the CPU per event of ``--events`` alphas after 50 warm-up events (5.3 MeV, isotropic,
20 nm exponential depth, lite physics). Rounds interleave the cases; each row is the median of
its rounds, with the load at the start and end.

Cases (10 um square pyramids, 10 um high, on a silicon face):

``face1m2``, ``face10m2``
    1 m x 1 m and 3.16 m x 3.16 m faces of 0.5 mm patches of 50 x 50 pyramids (one variant;
    2000^2 and 6320^2 cells in the nested layout).
``spikes50``, ``spikes1000``
    A 1 cm x 1 cm face: 20 x 20 patches of 50 x 50 pyramids, or one patch of 1000 x 1000
    pyramids (the paper's largest patch), each with ``solid: auto``; ``spikes1000_frustums``
    with ``solid: frustums`` (``_<solid>`` after any case name sets its solid).
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time

import numpy as np


def config(case: str, events: int) -> dict:
    """The run configuration of ``case``."""
    base, _, solid = case.partition("_")  # <case>_<solid>: that solid instead of auto
    side, n = {
        "face1m2": ("100 cm", 50),
        "face10m2": ("316 cm", 50),
        "spikes50": ("1 cm", 50),
        "spikes1000": ("1 cm", 1000),
    }[base]
    pyramids = {"kind": "spikes", "nx": n, "ny": n, "width": "10 um", "height": "10 um"}
    return {
        "physics": "lite",
        "surfaces": {"p": pyramids},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": [side, side, "1 mm"],
                "position": ["0 cm", "0 cm", "-0.5 mm"],
                "rough": [{"face": "+z", "surface": "p", "solid": solid or "auto"}],
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        "run": {"events": events, "seed": 3},
    }


def child(case: str, events: int) -> None:
    """Build ``case``, run it; print ``BUILD cpu_s rss_mb ms_per_event``."""
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    cfg = parse_config(config(case, events))
    c0 = time.process_time()
    sim = Simulation(plan_run(cfg, physics=resolve_physics("lite")))
    build = time.process_time() - c0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    primaries = sim.source.primaries(np.random.default_rng(5), 0, 50 + events)
    sim.run(primaries.select_events(0, 50), 1)
    c0 = time.process_time()
    sim.run(primaries.select_events(50, 50 + events), 2)
    per = (time.process_time() - c0) / events
    print(f"BUILD {build:.2f} {rss:.0f} {per * 1e3:.4f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", default="face1m2,face10m2,spikes50,spikes1000")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--events", type=int, default=1000)
    p.add_argument("--child", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(a.child, a.events)
        return
    from stamp import child_figures  # this folder is on sys.path when run as a script

    cases = [c for c in a.cases.split(",") if c]
    print(f"load average at start: {os.getloadavg()}")
    rows: dict[str, list[tuple[float, ...]]] = {}
    for _ in range(a.repeat):
        for case in cases:
            cmd = [sys.executable, __file__, "--child", case, "--events", str(a.events)]
            figures = child_figures(cmd, "BUILD")
            if isinstance(figures, str):
                print(f"{case}: {figures}")
                continue
            rows.setdefault(case, []).append(figures)
    print(f"load average at end: {os.getloadavg()}")
    print(
        f"{'case':12s} {'build CPU s':>11s} {'peak RSS MB':>11s} {'ms/event':>8s}"
        "  all rounds (s, MB, ms)"
    )
    for case, runs in rows.items():
        med = np.median(np.array(runs), axis=0)
        every = "  ".join(f"{b:.2f} {m:.0f} {e:.3f}" for b, m, e in runs)
        print(f"{case:12s} {med[0]:11.2f} {med[1]:11.0f} {med[2]:8.3f}  {every}")


if __name__ == "__main__":
    main()
