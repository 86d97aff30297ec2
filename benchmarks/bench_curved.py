"""A rough cylinder wall against the same pyramids on a flat face of equal area.

    .venv/bin/python benchmarks/bench_curved.py [--radius 40] [--half-length 40] [--events 400]

A silicon G4Tubs (GDML, written with pyg4ometry) with its outer wall rough (10 um pyramids,
50 x 50 to a 0.5 mm patch: bent tessellated bodies in rings, score4.world.curved), and a box of the
configuration whose +z face has the wall's area, rough with the same pyramids (as multi-union,
``solid: auto``, and as tessellated bodies). Each case is run twice with ``score4 run`` in a
child process (5.3 MeV alphas, isotropic, from the rough face, exponential depth of mean 1 um),
with ``--events 20`` and ``--events N``; the CPU time of the children gives the build and
start-up (the short run less its events) and the CPU time per event (the difference over the
extra events). Peak memory is the largest resident set of the children. Prints one table.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

SCORE4 = [sys.executable, "-m", "score4", "-q", "run"]
PYRAMIDS = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
SOURCE = {
    "particle": "alpha",
    "energy": "5.3 MeV",
    "direction": "isotropic",
    "depth": {"profile": "exponential", "mean": "1 um"},
}


def write_cylinder(path: Path, radius: float, half_length: float) -> None:
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    side = 4 * (radius + half_length)
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", side, side, side, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Tubs("cyl_s", 0, radius, 2 * half_length, 0, 2 * math.pi, reg)
    cyl = pg.geant4.LogicalVolume(solid, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cyl, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))


def configs(folder: Path, radius: float, half_length: float) -> dict[str, dict]:
    write_cylinder(folder / "cyl.gdml", radius, half_length)
    area = 2 * math.pi * radius * 2 * half_length
    side = math.floor(math.sqrt(area) / 0.5) * 0.5  # whole 0.5 mm patches
    out = {
        "curved wall (tessellated)": {
            "physics": "lite",
            "world": {"gdml": "cyl.gdml"},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "cyl", "rough": [{"face": "outer", "surface": "p"}]}],
            "source": {**SOURCE, "surface": {"volume": "cyl", "face": "outer"}},
        }
    }
    for solid in ("multiunion", "tessellated"):
        out[f"flat face ({solid})"] = {
            "physics": "lite",
            "surfaces": {"p": PYRAMIDS},
            "targets": [
                {
                    "name": "cyl",
                    "material": "G4_Si",
                    "size": [f"{side} mm", f"{side} mm", "1 mm"],
                    "rough": [{"face": "+z", "surface": "p", "solid": solid}],
                }
            ],
            "source": {**SOURCE, "surface": {"volume": "cyl", "face": "+z"}},
        }
    return out


def measure(folder: Path, name: str, config: dict, events: int) -> tuple[float, float, float]:
    """(CPU s of a 20-event run less its events, CPU s per event, peak RSS MB) of one case."""
    path = folder / f"{name.split()[0]}_{len(name)}.yaml"
    path.write_text(yaml.safe_dump(config))
    cpu = []
    for n in (20, events):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(
            [*SCORE4, str(path), "--events", str(n), "--out", str(folder / "o.h5"), "--overwrite"],
            check=True,
            cwd=folder,
        )
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    per_event = (cpu[1] - cpu[0]) / (events - 20)
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return cpu[0] - 20 * per_event, per_event, peak


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--radius", type=float, default=40.0, help="cylinder radius, mm")
    parser.add_argument("--half-length", type=float, default=40.0, help="half length, mm")
    parser.add_argument("--events", type=int, default=400, help="events of the long run")
    args = parser.parse_args()
    print(f"load: {os.getloadavg()[0]:.2f}  {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cases = configs(folder, args.radius, args.half_length)
        rows = {name: measure(folder, name, cfg, args.events) for name, cfg in cases.items()}
    ref = rows["curved wall (tessellated)"][1]
    print(
        f"radius {args.radius:g} mm, length {2 * args.half_length:g} mm, 10 um pyramids, "
        f"0.5 mm patches, {args.events} alphas"
    )
    print(f"{'case':28s} {'build+start CPU s':>18s} {'CPU ms/event':>13s} {'curved/this':>12s}")
    for name, (build, per_event, peak) in rows.items():
        print(
            f"{name:28s} {build:18.1f} {per_event * 1e3:13.2f} {ref / per_event:12.2f}"
            f"   peak RSS so far {peak:.0f} MB"
        )
    print(
        "(peak RSS: the largest child so far; the curved case runs first, so its figure is its own)"
    )


if __name__ == "__main__":
    main()
