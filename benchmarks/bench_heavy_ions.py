"""Po-210 with heavy ions on TRIM trajectories against Geant4's own ion transport.

Runs the built-in Po-210 emitter (5.304 MeV alpha + 103 keV Pb-206 recoil, back to back, depth
exponential with 20 nm mean) under a flat silicon face and under the paper's 10 um pyramids,
once with ``physics.heavy_ions: trim`` (score4's default) and once with ``geant4``, each in its
own process, and prints per case: CPU seconds, the spectrum regions that the recoil decides,
and the events that deposit more than was emitted.

    python benchmarks/bench_heavy_ions.py [--events 3000] [--jobs 1] [--markdown]

``--markdown`` prints the rows of the table in docs/physics.md (checked by ``make docs-check``).
``--per-event`` prints instead the whole-process CPU per event of each case: a run of
``--events`` minus a run of a tenth of them, over the difference in events (start-up and library
building cancel), and the ratio ``trim`` / ``geant4`` per face: medians of ``--repeat`` (3)
alternating measurements.

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_heavy_ions.py.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

Q_MEV = 5.40747  # alpha 5.30433 + recoil 0.103144

CONFIG = """
physics: {{mode: lite, heavy_ions: {ions}}}
{surfaces}
targets:
  - name: crystal
    material: G4_Si
    size: [5 mm, 5 mm, 1 mm]
    position: [0 mm, 0 mm, -0.5 mm]
{rough}
source:
  decay: Po210
  direction: isotropic
  surface: {{volume: crystal, face: "+z"}}
  depth: {{profile: exponential, mean: 20 nm}}
run: {{events: {events}, seed: 1}}
"""
ROUGH = {
    "flat": ("", ""),
    "pyramids": (
        "surfaces:\n  pyramids: {kind: spikes, nx: 50, ny: 50, width: 10 um, height: 10 um}",
        '    rough:\n      - {face: "+z", surface: pyramids, base_thickness: 1 um}',
    ),
}

FACE_LABEL = {"flat": "flat", "pyramids": "pyramids 10 um"}


def run_case(face: str, ions: str, events: int, jobs: int, workdir: Path) -> dict:
    surfaces, rough = ROUGH[face]
    config = workdir / f"{face}_{ions}.yaml"
    config.write_text(CONFIG.format(ions=ions, surfaces=surfaces, rough=rough, events=events))
    out = workdir / f"{face}_{ions}.h5"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [
            sys.executable,
            "-m",
            "score4.cli.main",
            "run",
            str(config),
            "--out",
            str(out),
            "--jobs",
            str(jobs),
            "--overwrite",
            "-q",
        ],
        check=True,
        stdout=subprocess.DEVNULL,  # the "wrote ..." line; stdout is the table
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with h5py.File(out) as f:
        edep = f["events/edep/crystal"][:]
        emitted = f["events/primary_energy"][:]
    n = len(edep)

    def share(lo: float, hi: float) -> str:
        k = int(((edep >= lo) & (edep < hi)).sum())
        return f"{100 * k / n:5.2f} +- {100 * np.sqrt(k) / n:4.2f} %"

    over = edep > emitted + 1e-6
    return {
        "cpu": cpu,
        "recoil_only": share(0.05, 0.11),
        "partial": share(5.30433 - 0.1, Q_MEV - 1e-3),
        "whole": share(Q_MEV - 1e-3, 10.0),
        "over": f"{int(over.sum())} (max {1e3 * float((edep - emitted).max()):.2f} keV)",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=3000)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--markdown", action="store_true", help="rows of docs/physics.md's table")
    parser.add_argument("--per-event", action="store_true", help="CPU ms per event, see above")
    parser.add_argument("--repeat", type=int, default=3, help="with --per-event: repetitions")
    args = parser.parse_args()
    if args.per_event:
        per_event(args.events, args.jobs, args.repeat)
        return
    if args.markdown:
        print(
            "| face | heavy ions | recoil only, 50-110 keV | alpha + part of the recoil "
            "| alpha + whole recoil | events above emitted | CPU s |"
        )
        print("| --- | --- | --- | --- | --- | --- | --- |")
    else:
        print(
            f"{'face':9s} {'ions':6s} {'CPU s':>6s}  {'recoil only 50-110 keV':>22s}  "
            f"{'alpha + part of recoil':>22s}  {'alpha + whole recoil':>22s}  over emitted"
        )
    with tempfile.TemporaryDirectory() as tmp:
        for face in ROUGH:
            for ions in ("trim", "geant4"):
                r = run_case(face, ions, args.events, args.jobs, Path(tmp))
                if args.markdown:  # the CPU last: docs/checks.yaml masks it (machine-dependent)
                    cells = [FACE_LABEL[face], f"`{ions}`", r["recoil_only"], r["partial"]]
                    cells += [r["whole"], r["over"].split()[0], f"{r['cpu']:.1f}"]
                    print("| " + " | ".join(c.strip().replace("+-", "±") for c in cells) + " |")
                    continue
                print(
                    f"{face:9s} {ions:6s} {r['cpu']:6.1f}  {r['recoil_only']:>22s}  "
                    f"{r['partial']:>22s}  {r['whole']:>22s}  {r['over']}",
                    flush=True,
                )


def per_event(events: int, jobs: int, repeat: int) -> None:
    """CPU ms per event, (CPU(events) - CPU(events / 10)) / (0.9 events), per face and mode.

    The two modes alternate ``repeat`` times; medians are printed (a shared machine's load
    moves single measurements by tens of per cent)."""
    few = max(1, events // 10)
    with tempfile.TemporaryDirectory() as tmp:
        for face in ROUGH:
            ms: dict[str, list[float]] = {"trim": [], "geant4": []}
            for ions in ms:
                run_case(face, ions, few, jobs, Path(tmp))  # libraries built, caches warm
            for _ in range(repeat):
                for ions in ms:
                    short = run_case(face, ions, few, jobs, Path(tmp))["cpu"]
                    full = run_case(face, ions, events, jobs, Path(tmp))["cpu"]
                    ms[ions].append(1e3 * (full - short) / (events - few))
            for ions, values in ms.items():
                print(f"{face:9s} {ions:6s} {np.median(values):.3f} ms per event", flush=True)
            ratios = np.array(ms["trim"]) / np.array(ms["geant4"])
            print(f"{face:9s} trim / geant4 {np.median(ratios):.2f}", flush=True)


if __name__ == "__main__":
    main()
