"""How much a run's result depends on its TRIM trajectory library (the price of reusing histories).

Po-210 20 nm (mean, exponential) under a flat silicon face, the same events (primaries and
Geant4 seeds) replayed with libraries of different TRIM seeds: the spread of the fraction of
Pb-206 recoils that leave the face across libraries is the library's share of a run's error,
which more events cannot reduce; it is compared with the binomial error of the events. Also
prints the cost of a library (CPU, file size) and the spread of its mean range.

    python benchmarks/bench_trim_library_reuse.py [--events 3000] [--libraries 4] [--histories 1000]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from score4.runner.run_plan import plan_run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=3000)
    parser.add_argument("--libraries", type=int, default=4)
    parser.add_argument("--histories", type=int, default=1000)
    args = parser.parse_args()
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="score4-reuse-")  # cold cache

    from score4.inputs.config import parse_config
    from score4.ions.trim_library import cache_dir
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.runtime import redirect_native_output, resolve_physics
    from score4.sim.simulation import Simulation

    data = {
        "physics": {"mode": "lite", "trim_histories": args.histories},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["5 mm", "5 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
            }
        ],
        "source": {
            "decay": "Po210",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        "run": {"events": args.events, "seed": 1},
    }
    # Geant4's banner and messages to /dev/null: the output is the docs' transcript
    with redirect_native_output(Path(os.devnull)):
        sim = Simulation(plan_run(parse_config(data), physics=resolve_physics("lite")))
    transport = sim.heavy_ions
    assert transport is not None
    primaries = sim.source.events(1, 0, args.events)
    seeds = event_geant4_seeds(1, 0, args.events)
    recoil = primaries.particle == "Pb206"
    fractions, means, cpus = [], [], []
    for library_seed in range(101, 101 + args.libraries):
        transport.library_seed = library_seed
        transport._libraries.clear()
        t = time.process_time()
        lib = transport.library(sim.particle("Pb206"), "Pb206", _silicon(sim), 0.103144)
        cpus.append(time.process_time() - t)
        means.append(1e6 * lib.points[lib.offsets[1:] - 1, 0].mean())
        sim.run(primaries, seeds, endpoints=True)
        assert sim.endpoints is not None
        fractions.append(float((sim.endpoints[recoil, 3] > 0).mean()))
    n = int(recoil.sum())
    p = float(np.mean(fractions))
    size = np.mean([f.stat().st_size for f in cache_dir().glob("*.npz")]) / 1e6
    print(
        f"library of {args.histories} Pb-206 histories (103 keV, Si): "
        f"{np.mean(cpus):.1f} s CPU, {size:.1f} MB"
    )
    print(
        f"library mean range over {args.libraries} TRIM seeds: "
        + ", ".join(f"{m:.2f}" for m in means)
        + f" nm (spread {np.std(means, ddof=1):.2f} nm)"
    )
    print(
        f"escaping recoils, {n} recoils per run, per library: "
        + ", ".join(f"{f:.4f}" for f in fractions)
    )
    print(
        f"spread across libraries {np.std(fractions, ddof=1):.4f}; "
        f"binomial error of the events {np.sqrt(p * (1 - p) / n):.4f}"
    )


def _silicon(sim):
    return sim.geometry.scoring["crystal"][0].GetMaterial()


if __name__ == "__main__":
    main()
