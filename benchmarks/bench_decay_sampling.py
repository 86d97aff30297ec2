"""Decays sampled per second in numpy (issue 18: >= 10^6 per second), with the machine's load.

    python benchmarks/bench_decay_sampling.py [--decays 1000000] [--repeat 5]

Cases: the nuclide samplers of Pb-210 and Bi-214 (``DecayScheme.sample``: branch, beta energy,
cascade, conversion, X-rays/Auger), a U-238 segment (Rn-222 to Pb-210 in secular equilibrium,
``ChainEvents.sample``, with the Bi-214/Po-214 coincidences), and the full primaries of
``decay: Pb210`` (``DecayEmitter`` through ``make_primaries``: plus isotropic directions and
positions). Best of ``--repeat`` runs, wall-clock, one process.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from score4.decay.chain import ChainEvents, build_chain
from score4.decay.scheme import decay_scheme
from score4.source.decay_source import DecayEmitter
from score4.source.emitters import make_primaries


def best_rate(fn, n: int, repeat: int) -> tuple[float, float]:
    """(decays per second of the best run, rows per decay)."""
    best, rows = float("inf"), 0
    for _ in range(repeat):
        start = time.perf_counter()
        rows = fn(n)
        best = min(best, time.perf_counter() - start)
    return n / best, rows / n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--decays", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    pb210, bi214 = decay_scheme("Pb210"), decay_scheme("Bi214")
    segment = ChainEvents(build_chain("Rn222", "Pb210"), None, 1e-5)
    emitter = DecayEmitter("Pb210")

    def primaries(n: int) -> int:
        return len(make_primaries(emitter, rng, np.zeros((n, 3))))

    cases = {
        "Pb-210 (DecayScheme.sample)": lambda n: len(pb210.sample(rng, n).event),
        "Bi-214 (DecayScheme.sample)": lambda n: len(bi214.sample(rng, n).event),
        "Rn-222..Po-214 secular (ChainEvents.sample)": lambda n: len(
            segment.sample(rng, n)["event"]
        ),
        "Pb-210 primaries (make_primaries)": primaries,
    }
    print(f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    for name, fn in cases.items():
        fn(1000)  # warm-up (compiles the schemes)
        rate, rows = best_rate(fn, args.decays, args.repeat)
        print(f"{name:48s} {rate / 1e6:6.2f} M decays/s  {rows:5.2f} rows/decay")
    print(f"load average after:  {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
