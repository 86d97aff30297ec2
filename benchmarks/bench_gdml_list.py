"""Reading a GDML world of 10^4 volumes and listing it: ``score4 geometry list`` wall time.

    .venv/bin/python benchmarks/bench_gdml_list.py [--modules 100] [--per-module 99]

The world (written by Geant4's own writer in a spawned process): ``--modules`` copper module
boxes, each placed separately in the world, each holding ``--per-module`` germanium crystals
(one logical volume placed that many times): 1 + modules x (1 + per_module) physical volumes
(10 001 by default; a crystal logical volume is shared, so the tree holds 9 900 crystal
instances). Timed as the user runs it, ``score4 geometry list CONFIG`` in a fresh process:

  cold   no cached volume model: a Geant4 subprocess reads the GDML and writes the model
  warm   the model comes from score4's cache (keyed by the file's content)

Wall time and CPU time (the command and its subprocesses; on a shared machine the steadier
figure: the command is single-threaded, so on an idle machine wall ~ CPU).

The issue's bound: < 5 s.

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_gdml_list.py.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import resource
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path


def write_world(path: str, modules: int, per_module: int) -> None:
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    nist = g4.G4NistManager.Instance()
    vac, cu, ge = (nist.FindOrBuildMaterial(m) for m in ("G4_Galactic", "G4_Cu", "G4_Ge"))
    vec = g4.G4ThreeVector
    side = int(modules**0.5 + 0.999)
    world = g4.G4LogicalVolume(g4.G4Box("World", 60 * side, 60 * side, 100), vac, "World")
    world_pv = g4.G4PVPlacement(None, vec(), world, "World", None, False, 0)
    keep = [world, world_pv]
    crystal = g4.G4LogicalVolume(g4.G4Box("Crystal", 2, 2, 2), ge, "Crystal")
    keep.append(crystal)
    per_side = int(per_module**0.5 + 0.999)
    for m in range(modules):
        module = g4.G4LogicalVolume(g4.G4Box(f"Module{m}", 25, 25, 5), cu, f"Module{m}")
        x, y = (m % side - side / 2) * 60, (m // side - side / 2) * 60
        keep += [
            module,
            g4.G4PVPlacement(None, vec(x, y, 0), module, f"module{m}", world, False, m),
        ]
        for k in range(per_module):
            cx, cy = (
                (k % per_side - per_side / 2) * 5 + 2.5,
                (k // per_side - per_side / 2) * 5 + 2.5,
            )
            keep.append(
                g4.G4PVPlacement(None, vec(cx, cy, 0), crystal, "crystal", module, False, k)
            )
    parser = g4.G4GDMLParser()
    with redirect_native_output(Path(os.devnull)):  # the writer's progress lines: not the table's
        parser.Write(path, world_pv, True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--modules", type=int, default=100)
    ap.add_argument("--per-module", type=int, default=99)
    args = ap.parse_args()
    score4 = str(Path(sys.executable).with_name("score4"))
    with tempfile.TemporaryDirectory() as tmp:
        gdml = Path(tmp) / "many.gdml"
        with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
            pool.submit(write_world, str(gdml), args.modules, args.per_module).result()
        cfg = Path(tmp) / "list.yaml"
        cfg.write_text(
            f"world: {{gdml: {gdml}}}\ntargets: [{{volume: 'crystal[0]'}}]\n"
            "source: {surface: {volume: 'crystal[0]', face: '+z'}, particle: alpha, "
            "energy: 5 MeV}\n"
        )
        env = {**os.environ, "XDG_CACHE_HOME": str(Path(tmp) / "cache")}
        print(
            f"GDML: {gdml.stat().st_size / 1e6:.1f} MB, "
            f"{1 + args.modules * (1 + args.per_module)} physical volumes"
        )
        print(f"load: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}")
        for label in ("cold", "warm", "warm"):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            done = subprocess.run(
                [score4, "geometry", "list", str(cfg)], capture_output=True, text=True, env=env
            )
            wall = time.perf_counter() - t0
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
            assert done.returncode == 0, done.stderr
            lines = done.stdout.count("\n")
            print(
                f"{label:<5} score4 geometry list: {wall:.2f} s wall, {cpu:.2f} s CPU "
                f"(with its subprocesses; {lines} lines)"
            )
        print(f"load: {subprocess.run(['uptime'], capture_output=True, text=True).stdout.strip()}")


if __name__ == "__main__":
    main()
