"""CPU per Po-210 event with the TRIM replay against Geant4's own ion transport, side by side.

The case of ``bench_heavy_ions.py`` (Po-210, depth exponential with 20 nm mean, under a flat
silicon face and under 10 um pyramids, lite physics): for each face a ``heavy_ions: trim`` and
a ``heavy_ions: geant4`` process run *at the same time* (so both see the same machine load),
each builds its application, warms up (libraries built, caches filled) and then times
``--batches`` batches of ``--events`` events with its own process CPU clock. Printed: the
per-batch CPU per event of both, their medians and the ratio of the medians.

    python benchmarks/bench_replay_speed.py [--events 1000] [--batches 5] [--rounds 1]
        [--baseline OLD/src]

``--rounds`` repeats the pair of processes per face and prints the median of their ratios;
``--baseline`` times another score4 checkout's sources in the same rounds (before/after).
``--recoils`` times the replay alone (``HeavyIonTransport.transport``, us CPU per Pb-206
recoil, ``--batches`` passes over the recoils of ``--events`` events per process); ``--calls``
counts its navigator calls per recoil, by method (no timing).

On a machine shared with other jobs single timings move by tens of per cent; running the two
modes together and taking medians keeps their ratio steadier than timing them one after the
other.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

from score4.runner.run_plan import plan_run


def config(face: str, ions: str, events: int) -> dict:
    data: dict = {
        "physics": {"mode": "lite", "heavy_ions": ions},
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
        "run": {"events": events, "seed": 1},
    }
    if face == "pyramids":
        data["surfaces"] = {
            "pyramids": {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
        }
        data["targets"][0]["rough"] = [
            {"face": "+z", "surface": "pyramids", "base_thickness": "1 um"}
        ]
    return data


def batches(face: str, ions: str, events: int, count: int) -> list[float]:
    """CPU ms per event of ``count`` batches (run in a process of its own: ``--one``)."""
    from score4.inputs.config import parse_config
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    sim = Simulation(
        plan_run(parse_config(config(face, ions, events)), physics=resolve_physics("lite"))
    )
    sim.run(sim.source.events(1, 0, 200), event_geant4_seeds(1, 0, 200))  # warm up
    out = []
    for b in range(count):
        first = 1000 + b * events
        primaries = sim.source.events(1, first, events)
        seeds = event_geant4_seeds(1, first, events)
        t = time.process_time()
        sim.run(primaries, seeds)
        out.append(1e3 * (time.process_time() - t) / events)
    return out


def recoil_replays(face: str, events: int, count: int) -> list[float]:
    """CPU us per Pb-206 recoil of ``HeavyIonTransport.transport`` alone (no Geant4 event
    around it): the recoils of ``events`` Po-210 events, each with its own ReplayStream,
    ``count`` times over (``--recoils``; run in a process of its own)."""
    from score4.inputs.config import parse_config
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.heavy_ions import ReplayStream
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    sim = Simulation(
        plan_run(parse_config(config(face, "trim", events)), physics=resolve_physics("lite"))
    )
    sim.run(sim.source.events(1, 0, 200), event_geant4_seeds(1, 0, 200))  # warm up
    primaries = sim.source.events(1, 1000, events)
    transport, particle = sim.heavy_ions, sim.particle("Pb206")
    assert transport is not None
    rows = [int(r) for r in np.flatnonzero(primaries.particle == "Pb206")]
    out = []
    for _ in range(count):
        t = time.process_time()
        for r in rows:
            transport.transport(
                particle,
                "Pb206",
                float(primaries.energy[r]),
                primaries.position[r],
                primaries.direction[r],
                ReplayStream(7, 1, r),
            )
        out.append(1e6 * (time.process_time() - t) / len(rows))
    return out


def recoil_calls(face: str, events: int) -> dict[str, float]:
    """Navigator calls per Pb-206 recoil of ``HeavyIonTransport.transport``, by method, over
    the recoils of ``events`` Po-210 events (``--calls``; run in a process of its own)."""
    from collections import Counter

    from score4.inputs.config import parse_config
    from score4.sim.heavy_ions import ReplayStream
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    sim = Simulation(
        plan_run(parse_config(config(face, "trim", events)), physics=resolve_physics("lite"))
    )
    primaries = sim.source.events(1, 1000, events)
    transport, particle = sim.heavy_ions, sim.particle("Pb206")
    assert transport is not None
    calls: Counter[str] = Counter()

    class Counting:
        """The navigator, counting the calls made through it."""

        def __init__(self, nav) -> None:
            self._nav = nav

        def __getattr__(self, name: str):
            method = getattr(self._nav, name)

            def counted(*args):
                calls[name] += 1
                return method(*args)

            return counted

    transport.nav = Counting(transport.nav)
    rows = [int(r) for r in np.flatnonzero(primaries.particle == "Pb206")]
    for r in rows:
        transport.transport(
            particle,
            "Pb206",
            float(primaries.energy[r]),
            primaries.position[r],
            primaries.direction[r],
            ReplayStream(7, 1, r),
        )
    return {name: n / len(rows) for name, n in sorted(calls.items())}


def part_calls(events: int, baseline: str | None) -> None:
    """``--calls``: navigator calls per recoil, in processes of their own."""
    versions = {"this": None} if baseline is None else {"this": None, "baseline": baseline}
    for face in ("flat", "pyramids"):
        for name, src in versions.items():
            env = dict(os.environ)
            if src:
                env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
            out = subprocess.run(
                [sys.executable, __file__, "--one-calls", face, "--events", str(events)],
                capture_output=True,
                text=True,
                env=env,
                check=True,
            ).stdout
            line = next(x for x in out.splitlines() if x.startswith("RESULT "))
            calls = json.loads(line.removeprefix("RESULT "))
            shown = ", ".join(f"{k} {v:.2f}" for k, v in calls.items())
            print(
                f"{face:9s} {name}{f' ({src})' if src else ''}: navigator calls per recoil "
                f"{sum(calls.values()):.1f} ({shown})"
            )


def part_recoils(events: int, count: int, rounds: int, baseline: str | None) -> None:
    """``--recoils``: the replay alone, per recoil, in processes of their own, interleaved."""
    versions = {"this": None} if baseline is None else {"this": None, "baseline": baseline}
    print(f"load average at start: {os.getloadavg()}")
    for face in ("flat", "pyramids"):
        values: dict[str, list[float]] = {name: [] for name in versions}
        for _ in range(rounds):
            for name, src in versions.items():
                env = dict(os.environ)
                if src:
                    env["PYTHONPATH"] = os.pathsep.join(
                        p for p in (src, env.get("PYTHONPATH")) if p
                    )
                out = subprocess.run(
                    [
                        *(sys.executable, __file__, "--one-recoils", face),
                        *("--events", str(events), "--batches", str(count)),
                    ],
                    capture_output=True,
                    text=True,
                    env=env,
                    check=True,
                ).stdout
                line = next(x for x in out.splitlines() if x.startswith("RESULT "))
                values[name].extend(json.loads(line.removeprefix("RESULT ")))
        for name, src in versions.items():
            us = statistics.median(values[name])
            print(
                f"{face:9s} {name}{f' ({src})' if src else ''}: replay {us:.1f} us CPU per "
                f"recoil, median of {len(values[name])} passes over {events} events"
            )
    print(f"load average at the end: {os.getloadavg()}")


def _pair(face: str, events: int, count: int, src: str | None) -> dict[str, list[float]]:
    """The trim and geant4 processes of one face, side by side (``src``: another score4's
    sources first on the path); their per-batch CPU ms per event."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    runs = {
        ions: subprocess.Popen(
            [
                *(sys.executable, __file__, "--one", face, ions),
                *("--events", str(events), "--batches", str(count)),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
        )
        for ions in ("trim", "geant4")
    }
    values = {}
    for ions, run in runs.items():
        out, _ = run.communicate()
        line = next(x for x in out.splitlines() if x.startswith("RESULT "))
        values[ions] = json.loads(line.removeprefix("RESULT "))
    return values


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=1000)
    parser.add_argument("--batches", type=int, default=5)
    parser.add_argument("--rounds", type=int, default=1, help="pairs of processes per face")
    parser.add_argument(
        "--baseline", help="also time the score4 sources in this src folder, interleaved"
    )
    parser.add_argument(
        "--recoils", action="store_true", help="time the replay alone, us CPU per recoil"
    )
    parser.add_argument(
        "--calls", action="store_true", help="count the replay's navigator calls per recoil"
    )
    parser.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    parser.add_argument("--one-calls", help=argparse.SUPPRESS)
    parser.add_argument("--one-recoils", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        face, ions = args.one
        print("RESULT " + json.dumps(batches(face, ions, args.events, args.batches)))
        return
    if args.one_recoils:
        print("RESULT " + json.dumps(recoil_replays(args.one_recoils, args.events, args.batches)))
        return
    if args.one_calls:
        print("RESULT " + json.dumps(recoil_calls(args.one_calls, args.events)))
        return
    if args.calls:
        part_calls(args.events, args.baseline)
        return
    if args.recoils:
        part_recoils(args.events, args.batches, args.rounds, args.baseline)
        return
    versions = (
        {"this": None} if args.baseline is None else {"this": None, "baseline": args.baseline}
    )
    # one version, one round: the transcript docs/physics.md quotes
    plain = args.baseline is None and args.rounds == 1
    if not plain:
        print(f"load average at start: {os.getloadavg()}")
    for face in ("flat", "pyramids"):
        ratios: dict[str, list[float]] = {name: [] for name in versions}
        for _ in range(args.rounds):
            for name, src in versions.items():
                label = f"{face:9s} " if plain else f"{face:9s} {name:8s} "
                values = _pair(face, args.events, args.batches, src)
                medians = {ions: statistics.median(v) for ions, v in values.items()}
                for ions, v in values.items():
                    shown = ", ".join(f"{x:.3f}" for x in v)
                    print(f"{label}{ions:6s} {shown} ms per event, median {medians[ions]:.3f}")
                ratios[name].append(medians["trim"] / medians["geant4"])
                print(f"{label}trim / geant4 {ratios[name][-1]:.2f}", flush=True)
        if plain:
            continue
        for name, src in versions.items():
            shown = ", ".join(f"{x:.2f}" for x in ratios[name])
            print(
                f"{face:9s} {name}{f' ({src})' if src else ''}: trim / geant4, median of "
                f"{args.rounds} rounds {statistics.median(ratios[name]):.2f} ({shown})"
            )
    if not plain:
        print(f"load average at the end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
