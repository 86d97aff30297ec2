"""Geant4's build and per-event cost of a rough cone face with many envelope pieces against the
same face with few (issue 24).

    .venv/bin/python benchmarks/bench_envelope_pieces.py [--events 2000] [--rounds 3]
        [--cases cone,taper]

A cone whose rings keep different azimuth ranges (a plane cutting it obliquely) gets one
envelope piece per group of rings keeping the same azimuths
(score4.world.boolean_layers._wall_pieces, session 12): one per ring when the cut crosses
every ring at another azimuth. ``many`` is that; ``few`` is the same face, the same cells and
patches, with each run of rings in one piece holding every ring's azimuths (the rule before:
the groups test made to say every ring keeps its neighbour's azimuths), which is sound where
nothing stands in the region a piece then holds beyond its rings' cells.

* ``cone``: a germanium G4Cons (r 5 -> 8 mm over 40 mm) less a box whose face cuts it along a
  plane leaning 0.1 rad off its axis (from x = 0 at its narrow end to x = 4 mm at its wide end),
  its wall rough (50 x 50 pyramids of 10 um on 0.5 mm patches): about 80 rings, a piece each.
* ``taper``: LEGEND's P00664B (tests/helpers/boolean_worlds.py), its lower taper (seg_1, a
  cone r 33 -> 35 mm over 2 mm) rough: 5 pieces against 1.

Each case runs in a child process that builds it as a worker does (``Simulation``, the world
built in Geant4 included), then tracks 20 events (the first run closes the geometry: Geant4's
voxels) and times ``--events`` more (5.3 MeV alphas, isotropic, from the rough face, 1 um
exponential depth) as one chunk. Printed per case: the pieces, the child's CPU
(``time.process_time``) for the build and for the first 20 events, its peak RSS at the end
(``ru_maxrss``) and the CPU per event of the chunk; medians over interleaved rounds (many,
few, many, ...), and per round the ratio many / few.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import yaml

PYRAMIDS = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
SOURCE: dict[str, Any] = {
    "particle": "alpha",
    "energy": "5.3 MeV",
    "direction": "isotropic",
    "depth": {"profile": "exponential", "mean": "1 um"},
}
LEAN = 0.1  # the cutting plane's angle to the cone's axis, rad


def write_cut_cone(path: Path) -> None:
    """``cone``: a germanium G4Cons (r 5 -> 8 mm, z -20 .. 20 mm) less a box (100 mm) whose -x
    face is the plane through x = 2 mm at z = 0 leaning by LEAN toward +x going up (GDML
    text)."""
    c, s = math.cos(LEAN), math.sin(LEAN)
    centre = (2.0 + 50.0 * c, 0.0, -50.0 * s)  # 50 mm beyond the plane along its normal
    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    path.write_text(
        f"""<?xml version="1.0" encoding="UTF-8"?>
<gdml><define>
<rotation name="lean" y="{-math.degrees(LEAN)}" unit="deg"/>
</define><materials/><solids>
<box name="world_s" x="200" y="200" z="200" lunit="mm"/>
<cone name="cone_a" rmin1="0" rmax1="5" rmin2="0" rmax2="8" z="40" {full}/>
<box name="cone_b" x="100" y="100" z="100" lunit="mm"/>
<subtraction name="cone_s"><first ref="cone_a"/><second ref="cone_b"/>
  <position name="cone_p" x="{centre[0]}" y="0" z="{centre[2]}" unit="mm"/>
  <rotationref ref="lean"/></subtraction>
</solids><structure>
<volume name="cone_lv"><materialref ref="G4_Ge"/><solidref ref="cone_s"/></volume>
<volume name="W"><materialref ref="G4_Galactic"/><solidref ref="world_s"/>
<physvol name="cone"><volumeref ref="cone_lv"/></physvol></volume>
</structure><setup name="Default" version="1.0"><world ref="W"/></setup></gdml>
"""
    )


def configs(folder: Path, cases: list[str]) -> dict[str, dict]:
    """The cases' configurations, their GDML worlds written to ``folder``."""
    out = {}
    if "cone" in cases:
        write_cut_cone(folder / "cone.gdml")
        out["cone"] = {
            "physics": "lite",
            "world": {"gdml": "cone.gdml"},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "cone", "rough": [{"face": "first.outer", "surface": "p"}]}],
            "source": SOURCE | {"surface": {"volume": "cone", "face": "first.outer"}},
        }
    if "taper" in cases:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from helpers.boolean_worlds import write_world  # LEGEND's P00664B, cut by a box

        write_world(folder / "boolean.gdml")
        out["taper"] = {
            "physics": "lite",
            "world": {"gdml": "boolean.gdml"},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "ppc", "rough": [{"face": "first.seg_1", "surface": "p"}]}],
            "source": SOURCE | {"surface": {"volume": "ppc", "face": "first.seg_1"}},
        }
    return out


def child(path: Path, pieces: str, events: int) -> None:
    """Build ``path``'s case in this process as a worker does (``pieces``: ``many`` as score4
    lays them out, ``few``: a piece per run of rings), track 20 events, then time ``events``
    more as one chunk. Prints the pieces, the CPU s of the build and of the first 20 events, the
    peak RSS MB and the CPU s per event of the chunk."""
    import resource
    import time

    import score4.world.boolean_layers as boolean_layers
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    if pieces == "few":
        boolean_layers._same_ranges = lambda a, b: True  # every ring as its neighbour
    os.chdir(path.parent)
    config = parse_config(yaml.safe_load(path.read_text()))
    c0 = time.process_time()
    plan = plan_run(config, physics=resolve_physics("lite"))
    sim = Simulation(plan)
    build = time.process_time() - c0
    n_pieces = sum(len(getattr(layer, "pieces", None) or ()) for layer in plan.scene.layers)
    seed = config.run.seed
    cpu = []
    for first, n in ((0, 20), (20, events)):
        c0 = time.process_time()
        sim.run(sim.source.events(seed, first, n), event_geant4_seeds(seed, first, n))
        cpu.append(time.process_time() - c0)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{n_pieces} {build:.3f} {cpu[0]:.3f} {peak:.1f} {cpu[1] / events:.9f}", flush=True)
    os._exit(0)  # skip Geant4's teardown


def measure(path: Path, pieces: str, events: int) -> tuple[int, float, float, float, float]:
    proc = subprocess.run(
        [
            sys.executable,
            __file__,
            "--child",
            str(path),
            "--pieces",
            pieces,
            "--events",
            str(events),
        ],
        cwd=path.parent,
        capture_output=True,
        text=True,
        check=True,
    )
    n, build, first, peak, per_event = proc.stdout.split()[-5:]
    return int(n), float(build), float(first), float(peak), float(per_event)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=2000, help="events of the timed chunk")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds")
    parser.add_argument("--cases", default="cone,taper", help="cone, taper")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--pieces", choices=["many", "few"], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.pieces, args.events)
        return
    cases = args.cases.split(",")
    with open("/proc/loadavg") as f:
        print(f"load before: {f.read().split()[:3]}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        paths = {}
        for name, data in configs(folder, cases).items():
            paths[name] = folder / f"{name}.yaml"
            paths[name].write_text(yaml.safe_dump(data))
        got: dict[tuple[str, str], list] = {}
        for _ in range(args.rounds):
            for name in cases:
                for pieces in ("many", "few"):
                    got.setdefault((name, pieces), []).append(
                        measure(paths[name], pieces, args.events)
                    )
    with open("/proc/loadavg") as f:
        print(f"load after: {f.read().split()[:3]}")
    print(f"{args.events} events per timed chunk, {args.rounds} interleaved rounds, medians")
    print(
        f"{'case':8} {'pieces':>7} {'build CPU s':>12} {'first 20 ev. s':>15} {'peak MB':>8} "
        f"{'CPU us/event':>13}"
    )
    for name in cases:
        for pieces in ("many", "few"):
            rows = got[name, pieces]
            n = rows[0][0]
            build, first, peak, event = (
                statistics.median(r[k] for r in rows) for k in (1, 2, 3, 4)
            )
            print(
                f"{name:8} {n:>7} {build:>12.2f} {first:>15.2f} {peak:>8.0f} {event * 1e6:>13.1f}"
            )
        many, few = got[name, "many"], got[name, "few"]
        ratios = [[a[k] / b[k] for k in (1, 2, 3, 4)] for a, b in zip(many, few, strict=True)]
        labels = ("build CPU", "first 20 events CPU", "peak RSS", "CPU per event")
        for k, label in enumerate(labels):
            values = ", ".join(f"{r[k]:.3f}" for r in ratios)
            print(f"{name}: {label} many / few per round: {values}")


if __name__ == "__main__":
    main()
