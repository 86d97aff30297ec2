"""A rough cylinder wall against the same pyramids on a flat face of equal area.

    .venv/bin/python benchmarks/bench_curved.py [--radius 40] [--half-length 40] [--events 3000]
        [--rounds 3] [--cases frustums,tessellated,flat] [--markdown] [--baseline OLD/src]
    .venv/bin/python benchmarks/bench_curved.py --spectra 3000

A silicon G4Tubs (GDML, written with pyg4ometry) with its outer wall rough (10 um pyramids, 50 x 50
to a 0.5 mm patch, bent onto the wall in rings, score4.world.curved) as bent G4Trds (``frustums``,
what ``solid: auto`` picks for spike grids on a cylinder) or as one bent tessellated body per patch
(``tessellated``), and a box of the configuration whose +z face has the wall's area, rough with the
same pyramids (``flat``: multi-union, ``solid: auto``; ``flat_tess``: tessellated bodies);
``whole``: the wall and both end faces rough (an HPGe crystal's whole surface; alphas from all
three faces); ``bege``: seven faces of a LEGEND BEGe (examples/bege/write_bege.py --metadata),
``bege_all``: its whole surface (``face: all``: the contact, the rings of the bottom, the groove,
the tapers, the side and the top; alphas from all of it); ``ppc_wall``: the side wall of LEGEND's
P00664B, a polycone less a box (tests/helpers/boolean_worlds.py), whose envelope holds the
kept cells' azimuths, ``ppc_cut_wall``: the same with the cut face rough too (alphas from the
wall in both). Each case runs with ``score4 run`` in a
child process (5.3 MeV alphas, isotropic, from the rough face, exponential depth of mean 1 um)
with ``--events 20``: its CPU time (``os.wait4``) less its events gives the build and start-up,
and its peak resident set (of its largest process) the memory of the build. The CPU time per
event comes from a second child that builds the case as a worker does and then draws and tracks
N events as one chunk (confinement of the drawn points included). The cases run in interleaved
rounds; the table gives medians over the rounds, the ratio column the median of the per-round
ratios to the flat face's CPU per event.

``--spectra N`` instead runs N alphas (seed 1) on the wall as bent G4Trds and as bent
tessellated bodies (one body, two representations) and compares their deposits.
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

SCORE4 = [sys.executable, "-m", "score4", "-q", "run"]
PYRAMIDS = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
SOURCE: dict[str, Any] = {
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


def write_cone(path: Path, radius: float, half_length: float) -> None:
    """A silicon G4Cons at 45 degrees whose side has the cylinder wall's area: mean radius
    ``radius``, generator ``2 half_length``."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    dr = half_length / math.sqrt(2)  # half the radius change and half the height
    side = 4 * (radius + half_length)
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", side, side, side, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Cons(
        "cone_s", 0, radius - dr, 0, radius + dr, 2 * dr, 0, 2 * math.pi, reg
    )
    cone = pg.geant4.LogicalVolume(solid, "G4_Si", "Cone", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cone, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))


def write_orb(path: Path, radius: float) -> None:
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 4 * radius, 4 * radius, 4 * radius, reg),
        "G4_Galactic",
        "World",
        reg,
    )
    orb = pg.geant4.LogicalVolume(pg.geant4.solid.Orb("orb_s", radius, reg), "G4_Si", "Orb", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], orb, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))


#: The BEGe's faces of the ``bege`` case (seven of its ten; ``bege_all``: every face,
#: ``face: all``).
BEGE_FACES = ["seg_1", "seg_2", "seg_3", "seg_4", "seg_5", "seg_6", "seg_7"]

CASES = {
    "frustums": "curved wall, bent G4Trds (solid: auto)",
    "tessellated": "curved wall, bent tessellated bodies",
    "cone": "45 degree cone side, bent G4Traps (solid: auto)",
    "cone_tess": "45 degree cone side, bent tessellated bodies",
    "bege": "BEGe, 7 of its 10 faces rough (solid: auto)",
    "bege_all": "BEGe, its whole surface rough (face: all)",
    "orb": "orb of equal area, whole sphere rough",
    "whole": "whole surface: wall and both ends rough (solid: auto)",
    "ppc_wall": "P00664B (a PPC less a box), its side wall rough (cut by the box)",
    "ppc_cut_wall": "P00664B, its cut face and side wall rough together",
    "flat": "flat face of equal area, multi-union (solid: auto)",
    "flat_tess": "flat face of equal area, tessellated",
}


def configs(folder: Path, radius: float, half_length: float, bege: bool = True) -> dict[str, dict]:
    """The cases' configurations, their GDML worlds written to ``folder`` (``bege``: also the
    BEGe's, which takes seconds: only for the bege cases)."""
    write_cylinder(folder / "cyl.gdml", radius, half_length)
    area = 2 * math.pi * radius * 2 * half_length
    side = math.floor(math.sqrt(area) / 0.5) * 0.5  # whole 0.5 mm patches
    out = {}
    for case, solid in (("frustums", "auto"), ("tessellated", "tessellated")):
        out[case] = {
            "physics": "lite",
            "world": {"gdml": "cyl.gdml"},
            "surfaces": {"p": PYRAMIDS},
            "targets": [
                {"volume": "cyl", "rough": [{"face": "outer", "surface": "p", "solid": solid}]}
            ],
            "source": SOURCE | {"surface": {"volume": "cyl", "face": "outer"}},
        }
    write_cone(folder / "cone.gdml", radius, half_length)
    for case, solid in (("cone", "auto"), ("cone_tess", "tessellated")):
        out[case] = {
            **out["frustums"],
            "world": {"gdml": "cone.gdml"},
            "targets": [
                {"volume": "cyl", "rough": [{"face": "outer", "surface": "p", "solid": solid}]}
            ],
        }
    write_orb(folder / "orb.gdml", math.sqrt(radius * half_length))  # 4 pi r^2 = the wall's
    out["orb"] = {**out["frustums"], "world": {"gdml": "orb.gdml"}}
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples" / "bege"))
    from write_bege import main as write_bege

    if bege:
        write_bege(str(folder / "bege.gdml"), metadata=True)  # as examples/rough_hpge writes it
    for case, faces in (("bege", BEGE_FACES), ("bege_all", "all")):
        out[case] = {
            "physics": "lite",
            "world": {"gdml": "bege.gdml"},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "bege", "rough": [{"face": faces, "surface": "p"}]}],
            "source": SOURCE | {"surface": {"volume": "bege", "face": faces}},
        }
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from helpers.boolean_worlds import write_world  # LEGEND's P00664B, cut by a box

    write_world(folder / "boolean.gdml")
    for case, faces in (
        ("ppc_wall", ["first.seg_2"]),
        ("ppc_cut_wall", ["second.-x", "first.seg_2"]),
    ):
        out[case] = {
            "physics": "lite",
            "world": {"gdml": "boolean.gdml"},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "ppc", "rough": [{"face": f, "surface": "p"} for f in faces]}],
            "source": SOURCE | {"surface": {"volume": "ppc", "face": "first.seg_2"}},
        }
    out["whole"] = {
        "physics": "lite",
        "world": {"gdml": "cyl.gdml"},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {"volume": "cyl", "rough": [{"face": f, "surface": "p"} for f in ("outer", "+z", "-z")]}
        ],
        "source": SOURCE | {"surface": {"volume": "cyl", "face": ["outer", "+z", "-z"]}},
    }
    for case, solid in (("flat", "auto"), ("flat_tess", "tessellated")):
        out[case] = {
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
            "source": SOURCE | {"surface": {"volume": "cyl", "face": "+z"}},
        }
    return out


# Runs the command from a small process and reports the command's own rusage: a child forked
# from this (large) process would count this process's resident set in its ru_maxrss.
_LAUNCH = (
    "import os, subprocess, sys\n"
    "p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)\n"
    "_, status, u = os.wait4(p.pid, 0)\n"
    "print(os.waitstatus_to_exitcode(status), u.ru_utime + u.ru_stime, u.ru_maxrss)\n"
)


def child_cpu(cmd: list[str], cwd: Path, src: str | None = None) -> tuple[float, float]:
    """(CPU s, peak RSS MB) of one child process (``src``: import score4 from there)."""
    env = {**os.environ, "PYTHONPATH": src} if src else None
    out = subprocess.run(
        [sys.executable, "-c", _LAUNCH, *cmd],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    code, cpu, maxrss = int(out[-3]), float(out[-2]), float(out[-1])
    if code:
        raise SystemExit(f"failed ({code}): {' '.join(cmd)}")
    return cpu, maxrss / 1024


def measure(
    folder: Path, name: str, config: dict, events: int, src: str | None = None
) -> tuple[float, float, float]:
    """(CPU s of a 20-event run less its events, CPU s per event, peak RSS MB of the 20-event
    run) of one case (``src``: with score4 imported from that folder, a baseline)."""
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(config))
    out = folder / f"{name}.h5"
    cpu, peak = child_cpu(
        [*SCORE4, str(path), "--events", "20", "--out", str(out), "--overwrite"],
        folder,
        src,
    )
    proc = subprocess.run(
        [sys.executable, __file__, "--child", str(path), "--events", str(events)],
        cwd=folder,
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": src} if src else None,
    )
    per_event = float(proc.stdout.split()[-2])  # the child's peak holds its N events' data
    return cpu - 20 * per_event, per_event, peak


def child(path: Path, events: int) -> None:
    """Build ``path``'s case in this process as a worker does, track 20 events, then time
    ``events`` more: drawn (``Source.events``, confinement included) and tracked as one chunk.
    Prints ``CPU s per event`` and the process's peak RSS MB."""
    import resource
    import time

    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    os.chdir(path.parent)
    config = parse_config(yaml.safe_load(path.read_text()))
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")))
    seed = config.run.seed
    for first, n in ((0, 20), (20, events)):
        c0 = time.process_time()
        sim.run(sim.source.events(seed, first, n), event_geant4_seeds(seed, first, n))
        per_event = (time.process_time() - c0) / n
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{per_event:.9f} {peak:.1f}", flush=True)
    os._exit(0)  # skip Geant4's teardown


def compare_spectra(radius: float, half_length: float, events: int) -> None:
    """The same alphas (seed 1) on the wall as bent G4Trds and as bent tessellated bodies (one
    body, two representations): events with the same deposit, KS p, means and full-energy
    shares."""
    import numpy as np
    from scipy.stats import ks_2samp

    from score4.runner.output import read_results

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        cases = configs(folder, radius, half_length)
        for name in ("frustums", "tessellated"):
            path = folder / f"{name}.yaml"
            path.write_text(yaml.safe_dump(cases[name]))
            h5 = folder / f"{name}.h5"
            child_cpu([*SCORE4, str(path), "--events", str(events), "--out", str(h5)], folder)
            out[name] = np.asarray(read_results(h5).edep["cyl"])
    a, b = out["frustums"], out["tessellated"]
    se = math.sqrt((a.var() + b.var()) / len(a))
    print(f"{events} alphas, seed 1, radius {radius:g} mm, length {2 * half_length:g} mm")
    print(f"same deposit (1e-9 MeV): {(np.abs(a - b) <= 1e-9).sum()} of {len(a)} events")
    print(f"mean deposit MeV: G4Trds {a.mean():.4f}, tessellated {b.mean():.4f} (s.e. {se:.4f})")
    print(f"full energy (> 5.2 MeV): {(a > 5.2).mean():.4f} vs {(b > 5.2).mean():.4f}")
    print(f"two-sample KS p = {ks_2samp(a, b).pvalue:.3f}")


def main() -> None:
    from stamp import stamp  # this folder is on sys.path when run as a script

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--radius", type=float, default=40.0, help="cylinder radius, mm")
    parser.add_argument("--half-length", type=float, default=40.0, help="half length, mm")
    parser.add_argument("--events", type=int, default=3000, help="events of the long run")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds")
    parser.add_argument(
        "--cases", default="frustums,tessellated,flat", help=f"of {', '.join(CASES)}"
    )
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    parser.add_argument(
        "--baseline",
        default=None,
        help="also run each case (but flat) with score4 imported from this src folder "
        "(an older checkout), interleaved",
    )
    parser.add_argument(
        "--spectra",
        type=int,
        default=0,
        help="instead: N alphas (seed 1) on the wall as bent G4Trds and as bent tessellated "
        "bodies; compare their deposits",
    )
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.events)
        return
    if args.spectra:
        compare_spectra(args.radius, args.half_length, args.spectra)
        return
    names = args.cases.split(",")
    print(stamp())
    runs = [(n, n, None) for n in names]
    if args.baseline:
        # (a baseline before session 11 refuses the cut face and the side wall together)
        runs += [
            (f"{n} (baseline)", n, args.baseline)
            for n in names
            if n not in ("flat", "ppc_cut_wall")
        ]
    rows: dict[str, list[tuple[float, float, float]]] = {label: [] for label, _, _ in runs}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        bege = any(name.startswith("bege") for name in names)
        cases = configs(folder, args.radius, args.half_length, bege)
        for _ in range(args.rounds):
            for label, name, src in runs:
                rows[label].append(measure(folder, name, cases[name], args.events, src))
    print(f"load at the end {os.getloadavg()[0]:.1f}")
    area = 2 * math.pi * args.radius * 2 * args.half_length
    print(
        f"radius {args.radius:g} mm, length {2 * args.half_length:g} mm "
        f"({area:.0f} mm2), 10 um pyramids, 0.5 mm patches, {args.events} alphas, "
        f"medians of {args.rounds} interleaved rounds"
    )
    ref = rows.get("flat")
    table = []
    for name, r in rows.items():
        build, per_event, peak = (statistics.median(x) for x in zip(*r, strict=True))
        ratio = (
            statistics.median(a[1] / b[1] for a, b in zip(r, ref, strict=True)) if ref else math.nan
        )
        what = CASES[name.split(" ")[0]] + (" (baseline)" if name.endswith("(baseline)") else "")
        table.append((what, build, per_event * 1e3, peak, ratio))
    if args.markdown:
        print(
            "| case | build and start-up s CPU | ms CPU per alpha event "
            "| peak RSS MB (20 events) | ratio |"
        )
        print("| --- | --- | --- | --- | --- |")
        for what, build, ms, peak, ratio in table:
            print(f"| {what} | {build:.1f} | {ms:.2f} | {peak:.0f} | {ratio:.2f} |")
        return
    head = f"{'build+start CPU s':>18s} {'CPU ms/event':>13s} {'peak MB':>8s} {'/flat':>6s}"
    print(f"{'case':60s} {head}")
    for what, build, ms, peak, ratio in table:
        print(f"{what:60s} {build:18.1f} {ms:13.2f} {peak:8.0f} {ratio:6.2f}")


if __name__ == "__main__":
    main()
