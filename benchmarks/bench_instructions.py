"""Instructions per alpha event on rough faces, counted by valgrind's callgrind: a figure the
machine's load does not move.

    .venv/bin/python benchmarks/bench_instructions.py [--cases pyramids,gauss_blocks]
        [--events 300] [--face 1.5] [--set score4.surface.block_cut.FLOOR_GAP=5e-4] [--keep DIR]

Each case (benchmarks/bench_surfaces.py's cases, ``<case>_b<N>`` for ``block_cells: N``, or
``runloop_native`` and ``runloop_portal``: bench_runloop.py's portal part, Po-210 on the 10 cm
face, where ``--face`` does not apply) runs in
its own process under ``valgrind --tool=callgrind --instr-atstart=no``: it builds the face,
runs 200 warm-up events, then the parent switches instrumentation on (``callgrind_control -i
on``) for ``--events`` alpha events in one BeamOn and off again before the process tears down.
The figure is the instructions of that BeamOn over the events (Geant4 and the Python around it),
with the ratio to the equal-height pyramid face (``pyramids``) of the same run when it is among
the cases, and the number of "Stuck Track" warnings (Geant4's push after 10 zero steps).
``--set MODULE.NAME=VALUE`` sets a module constant in the child before it builds (to compare a
floor gap or a block size without editing the sources); ``--profile N`` also prints the N
functions with the most instructions of each case (callgrind_annotate, exclusive).

Instruction counts are not CPU time (cache misses and branch mispredictions do not count), but
they move with the work the navigator does per step, and a loaded machine leaves them alone;
bench_surfaces.py --warm --faces measures CPU time. Callgrind runs ~50x slower than native:
300 events of a Gaussian map take 2-4 minutes. The same events (seed 5) run in every case, so
the figures differ only through the geometry.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WARMUP = 200


def child(case: str, events: int, face: float, sets: list[str]) -> None:
    """Build ``case``, run the warm-up, then one timed BeamOn between two handshakes on
    stdin/stdout (the parent switches callgrind's instrumentation on and off there)."""
    for item in sets:
        target, _, value = item.partition("=")
        module, _, name = target.rpartition(".")
        mod = importlib.import_module(module)
        setattr(mod, name, type(getattr(mod, name))(float(value)))
    import numpy as np

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_surfaces import config

    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    if case.startswith("runloop_"):  # bench_runloop.py's portal part: Po-210, 10 cm face
        from bench_runloop import portal_config

        data = portal_config(case.removeprefix("runloop_"))
    else:
        data = config(case, events, face)
    sim = Simulation(plan_run(parse_config(data), physics=resolve_physics("lite")))
    primaries = sim.source.primaries(np.random.default_rng(5), 0, WARMUP + events)
    sim.run(primaries.select_events(0, WARMUP), 1)
    print("READY", flush=True)
    sys.stdin.readline()
    scores = sim.run(primaries.select_events(WARMUP, WARMUP + events), 2)
    print(f"DONE {float(scores['edep'][:, 0].mean()):.4f}", flush=True)
    sys.stdin.readline()


def measure(case: str, events: int, face: float, sets: list[str], tmp: Path, top: int):
    """(instructions per event, mean deposit MeV, stuck-track warnings) of one case."""
    out = tmp / f"{case}.callgrind"
    cmd = [
        "valgrind",
        "--tool=callgrind",
        "--instr-atstart=no",
        f"--callgrind-out-file={out}",
        sys.executable,
        __file__,
        "--child",
        case,
        "--events",
        str(events),
        "--face",
        str(face),
        *[a for s in sets for a in ("--set", s)],
    ]
    log = tmp / f"{case}.log"
    with log.open("w") as err:
        # lunasrim (TRIM, imported for the Po-210 recoils) runs x87 code valgrind cannot
        # decode unless told to use Python's math
        env = {**os.environ, "LUNASRIM_NO_NATIVE_MATH": "1"}
        proc = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, text=True, env=env
        )
        assert proc.stdin is not None
        assert proc.stdout is not None
        lines = []
        for mode in ("on", "off"):
            while not (line := proc.stdout.readline()).startswith(("READY", "DONE")):
                if not line:
                    raise RuntimeError(f"{case}: the child ended early; see {log}")
            lines.append(line)
            subprocess.run(
                ["callgrind_control", "-i", mode, str(proc.pid)], check=True, capture_output=True
            )
            proc.stdin.write("\n")
            proc.stdin.flush()
        proc.wait()
    text = out.read_text(errors="replace")
    found = re.search(r"^totals:\s+(\d+)", text, re.MULTILINE)
    if found is None:
        raise RuntimeError(f"{case}: no totals in {out}")
    total = int(found.group(1))
    stuck = log.read_text(errors="replace").count("Stuck Track")
    if top:
        ann = subprocess.run(["callgrind_annotate", str(out)], capture_output=True, text=True)
        rows = [r for r in ann.stdout.splitlines() if re.match(r"^\s*[\d,]+ \(", r)][1 : top + 1]
        for r in rows:
            print(f"    {r[:150]}")
    return total / events, float(lines[-1].split()[1]), stuck


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cases", default="pyramids,gauss_blocks,selfaff_blocks,measured_blocks")
    p.add_argument("--events", type=int, default=300)
    p.add_argument("--face", type=float, default=1.5, help="face side, mm")
    p.add_argument("--set", action="append", default=[], dest="sets", metavar="MODULE.NAME=VALUE")
    p.add_argument("--profile", type=int, default=0, metavar="N")
    p.add_argument("--keep", metavar="DIR", help="write the callgrind files to DIR (kept)")
    p.add_argument("--child", help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        child(a.child, a.events, a.face, a.sets)
        return
    print(
        f"load {os.getloadavg()[0]:.1f}; {a.events} alpha events, face {a.face} mm; {a.sets or ''}"
    )
    print("| case | M instructions per event | ratio to pyramids | mean MeV | stuck tracks |")
    print("| --- | --- | --- | --- | --- |")
    ref = None
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(a.keep or tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for case in a.cases.split(","):
            per, mean, stuck = measure(case, a.events, a.face, a.sets, folder, a.profile)
            ref = per if case == "pyramids" else ref
            ratio = f"{per / ref:.3f}" if ref else "-"
            print(f"| {case} | {per / 1e6:.3f} | {ratio} | {mean:.4f} | {stuck} |", flush=True)


if __name__ == "__main__":
    main()
