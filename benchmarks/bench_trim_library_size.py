"""How many histories a TRIM trajectory library needs: its build cost, and its own fluctuations.

A run replays its heavy ions on a library of ``physics.trim_histories`` TRIM histories, drawn
with replacement, so with many more recoils than histories a run's spectrum carries the
library's sample error on top of its own. This script measures both sides for the Pb-206 recoil
of Po-210 (103.14 keV) in germanium:

``--part cost``: per library size, in a fresh process each, the CPU time of building the library
(lunasrim TRIM, score4's builder), the growth of the process's peak memory while building it and
the size of its cache file.

``--part chi2``: the recoil's deposit in a germanium block (5 x 5 x 1 mm, Po-210 under its +z
face, depth exponential with 20 nm mean, isotropic) by score4's replay
(``HeavyIonTransport.transport``, with Geant4's navigator; the alpha is not tracked: only the
recoil's deposit is compared), in ``--bins`` equal bins from 0 to the recoil's energy, for
``--events`` events:

- runs on libraries of each size: disjoint slices of one library of TRIM seed
  ``library_trim_seed(1)`` (the first slice is the library a run of seed 1 builds for a recoil
  of this energy; a library of n histories is the first n of any larger one of the same seed),
  each replayed on the same events (primaries of seed 1);
- against an independent TRIM: other events (primaries of seed 2), each on its own history of a
  library of TRIM seed ``reference_trim_seed(1)`` used once (so every event is a fresh TRIM
  history, as if TRIM had been run for it).

Printed per size: the two-sample chi2/ndf of each slice against the reference (equal totals:
``sum (a - r)^2 / (a + r)``, ndf = bins - 1), their mean, and the variance factor of the run's
bins that it implies (``2 chi2/ndf - 1``: 1 when the library adds nothing). Expect chi2/ndf near
``1 + k N / (2 n)`` for N events and n histories, k between 0 and 1.

    python benchmarks/bench_trim_library_size.py [--part cost|chi2|all] [--sizes 1000,5000,20000]
        [--events 100000] [--replicas 3] [--bins 12] [--cache DIR]

``--cache``: where the libraries are kept (default: a new temporary folder; the chi2 part needs
``max(size x replicas)`` and ``--events`` histories, minutes of CPU: give a folder to keep them).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from stamp import stamp

CONFIG = {
    "physics": {"mode": "lite"},
    "targets": [
        {
            "name": "crystal",
            "material": "G4_Ge",
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
    "run": {"events": 1000, "seed": 1},
}


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def child_cost(n: int) -> None:
    """Build one library of ``n`` histories (this process's first) and print its cost."""
    from score4.ions.composition import Composition
    from score4.ions.trim_library import cache_dir, trim_library
    from score4.runner.seeds import library_trim_seed
    from score4.source.emitters import PO210_RECOIL_ENERGY

    germanium = Composition("G4_Ge", (("Ge", 1.0),), 5.323)  # as Geant4's G4_Ge gives it
    before = _rss_mb()
    cpu = time.process_time()
    lib = trim_library(
        "Pb206", 82, 205.9744651, float(PO210_RECOIL_ENERGY), germanium, n, library_trim_seed(1)
    )
    cpu = time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    size = sum(p.stat().st_size for p in cache_dir().glob("*.npz")) / 1e6
    print(f"cost {n} {cpu:.2f} {peak - before:.1f} {size:.2f} {len(lib.points) / n:.1f}")


def part_cost(sizes: list[int], cache: str) -> None:
    print(f"build cost of Pb-206 103.14 keV libraries in Ge ({stamp()}):")
    print("histories  CPU s  ms/history  peak memory growth MB  cache file MB  points/history")
    for n in sizes:
        env = {**os.environ, "XDG_CACHE_HOME": tempfile.mkdtemp(prefix="score4-size-", dir=cache)}
        r = subprocess.run(
            [sys.executable, __file__, "--child-cost", str(n)],
            check=False,
            capture_output=True,
            text=True,
            env=env,
        )
        rows = [x for x in r.stdout.splitlines() if x.startswith("cost ")]
        if r.returncode or not rows:
            print(f"{n:9d}  failed: {r.stderr.strip().splitlines()[-1:]}")
            continue
        _, _, cpu, grow, size, points = rows[-1].split()
        print(
            f"{n:9d}  {float(cpu):5.1f}  {1e3 * float(cpu) / n:10.2f}  {float(grow):21.0f}  "
            f"{float(size):13.1f}  {float(points):14.1f}"
        )


class _FreshHistory:
    """A replay stream whose first history choice is ``k`` (then ``rng``'s draws)."""

    def __init__(self, k: int, rng: np.random.Generator) -> None:
        self.k, self.rng = k, rng

    def integers(self, n: int) -> int:
        k, self.k = self.k, -1
        return k if k >= 0 else int(self.rng.integers(n))

    def uniform(self, a: float, b: float) -> float:
        return float(self.rng.uniform(a, b))


def _slice(lib, first: int, n: int):
    """Histories ``first .. first + n - 1`` of ``lib`` as a library of their own."""
    from score4.ions.trim_library import TrajectoryLibrary

    a, b = int(lib.offsets[first]), int(lib.offsets[first + n])
    return TrajectoryLibrary(
        lib.ion,
        lib.mass_amu,
        lib.energy,
        lib.material,
        lib.offsets[first : first + n + 1] - a,
        lib.points[a:b],
        lib.energies[a:b],
        lib.arrivals[a:b],
        lib.left[first : first + n],
    )


def part_chi2(sizes: list[int], events: int, replicas: int, bins: int, cache: str) -> None:
    """Print the comparison (Geant4's own output goes to a log in ``cache``)."""
    os.environ["XDG_CACHE_HOME"] = cache
    from score4.sim.runtime import redirect_native_output

    lines: list[str] = []
    with redirect_native_output(Path(cache) / "geant4.log"):
        _chi2(sizes, events, replicas, bins, lines.append)
    print("\n".join(lines))


def _chi2(sizes: list[int], events: int, replicas: int, bins: int, say) -> None:
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.runner.seeds import library_trim_seed, reference_trim_seed
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation
    from score4.source.emitters import PO210_RECOIL_ENERGY

    total = max(n * max(1, min(replicas, events // n)) for n in sizes)
    total = max(total, events)
    data = {**CONFIG, "physics": {"mode": "lite", "trim_histories": total}}
    sim = Simulation(plan_run(parse_config(data), physics=resolve_physics("lite")))
    transport = sim.heavy_ions
    assert transport is not None
    particle = sim.particle("Pb206")
    germanium = sim.geometry.scoring["crystal"][0].GetMaterial()

    def recoils(seed: int):
        """The recoils' energies, vertices and directions of the events of source seed ``seed``
        (all at the energy the cost part builds for: the decay data's differs by 0.3 eV)."""
        p = sim.source.events(seed, 0, events)
        rows = p.particle == "Pb206"
        return np.full(rows.sum(), float(PO210_RECOIL_ENERGY)), p.position[rows], p.direction[rows]

    def library(trim_seed: int):
        transport.library_seed = trim_seed
        transport._libraries.clear()
        t = time.process_time()
        lib = transport.library(particle, "Pb206", germanium, energy)
        return lib, time.process_time() - t

    energies, positions, directions = recoils(1)
    energy = float(energies[0])
    edges = np.linspace(0.0, energy * (1 + 1e-9), bins + 1)
    big, cpu_big = library(library_trim_seed(1))
    ref, cpu_ref = library(reference_trim_seed(1))

    def spectrum(lib, streams) -> tuple[np.ndarray, float]:
        transport.library = lambda *args, **kwargs: lib  # type: ignore[method-assign]
        t = time.process_time()
        deposit = np.empty(len(energies))
        for i, rng in enumerate(streams):
            fate = transport.transport(
                particle, "Pb206", energies[i], positions[i], directions[i], rng
            )
            deposit[i] = sum(fate.deposits.values())
        return np.histogram(deposit, edges)[0], time.process_time() - t

    say(
        f"recoil deposit of Po-210 (20 nm exponential, isotropic) in Ge: {len(energies)} events, "
        f"{bins} bins 0-{energy * 1e3:.2f} keV ({stamp()}); libraries of {total} histories built "
        f"in {cpu_big:.0f} + {cpu_ref:.0f} s CPU (0 if cached)"
    )
    energies, positions, directions = recoils(2)
    reference, cpu = spectrum(
        ref, (_FreshHistory(i, np.random.default_rng([2, i])) for i in range(len(energies)))
    )
    say(f"reference (each event its own TRIM history): {cpu:.0f} s CPU")
    say("reference counts: " + " ".join(str(c) for c in reference))
    energies, positions, directions = recoils(1)
    say("histories  slices  chi2/ndf of each slice           mean  variance factor")
    for n in sizes:
        chis = []
        for r in range(max(1, min(replicas, total // n))):
            counts, _ = spectrum(
                _slice(big, r * n, n),
                (np.random.default_rng([1, i]) for i in range(len(energies))),
            )
            both = counts + reference
            used = both > 0
            chis.append(float(((counts - reference)[used] ** 2 / both[used]).sum()) / (bins - 1))
        mean = float(np.mean(chis))
        say(
            f"{n:9d}  {len(chis):6d}  {' '.join(f'{c:5.2f}' for c in chis):30s}  {mean:5.2f}  "
            f"{2 * mean - 1:15.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", choices=("cost", "chi2", "all"), default="all")
    parser.add_argument("--sizes", default="1000,5000,20000")
    parser.add_argument("--events", type=int, default=100_000)
    parser.add_argument("--replicas", type=int, default=3)
    parser.add_argument("--bins", type=int, default=12)
    parser.add_argument("--cache", default=None)
    parser.add_argument("--child-cost", type=int, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child_cost is not None:
        child_cost(args.child_cost)
        return
    sizes = [int(s) for s in args.sizes.split(",")]
    cache = args.cache or tempfile.mkdtemp(prefix="score4-size-")
    Path(cache).mkdir(parents=True, exist_ok=True)
    if args.part in ("cost", "all"):
        part_cost(sizes, cache)
    if args.part in ("chi2", "all"):
        part_chi2(sizes, args.events, args.replicas, args.bins, cache)


if __name__ == "__main__":
    main()
