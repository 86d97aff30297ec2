"""``score4 geometry export`` of a roughened 8-crystal tower: file size, time and memory to write,
time to read back (Geant4, pyg4ometry).

    python benchmarks/bench_gdml_export.py [--crystals 8] [--size 20]

A GDML world (written by pyg4ometry) holds a tower of 8 germanium boxes (20 x 20 x 20 mm, 5 mm
apart along z, one logical volume placed 8 times); each crystal gets 4 rough faces (+x, -x, +y,
-y: 32 faces) of 10 um x 10 um pyramids (patches of 10 x 10 pyramids, native tiling, the default
multi-union patch solid). The export runs as the CLI runs it (a spawned Geant4 process);
memory is the peak resident size of that process (``ru_maxrss`` of the children). Geant4 reads
the file in a fresh process (time and peak memory), pyg4ometry in this one (no meshing).
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import resource
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import yaml


def write_tower(out: Path, n: int, size: float) -> None:
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    gap = 5.0
    height = n * (size + gap)
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 4 * size, 4 * size, height + 4 * size, reg),
        "G4_lAr",
        "World",
        reg,
    )
    crystal = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("crystal_s", size, size, size, reg), "G4_Ge", "Crystal", reg
    )
    for k in range(n):
        z = -height / 2 + (k + 0.5) * (size + gap)
        pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, z], crystal, f"det{k}", world, reg, copyNumber=k)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(out))


def _read_geant4(path: str) -> tuple[float, float, int]:
    from score4.geometry.gdml import read_gdml
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    t0, c0 = time.perf_counter(), time.process_time()
    with redirect_native_output(None):
        _parser, world = read_gdml(g4, path)
    n = world.GetLogicalVolume().GetNoDaughters()
    return time.perf_counter() - t0, time.process_time() - c0, n


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--crystals", type=int, default=8)
    ap.add_argument("--size", type=float, default=20.0, help="crystal edge, mm")
    args = ap.parse_args()
    with open("/proc/loadavg") as f:
        print(f"load at start: {f.read().split()[0]}")
    from score4.cli.main import main as score4

    with tempfile.TemporaryDirectory() as d:
        folder = Path(d)
        write_tower(folder / "tower.gdml", args.crystals, args.size)
        faces = ["+x", "-x", "+y", "-y"]
        config = {
            "physics": "lite",
            "world": {"gdml": "tower.gdml"},
            "surfaces": {
                "pyr": {
                    "kind": "spikes",
                    "shape": "pyramid",
                    "nx": 10,
                    "ny": 10,
                    "width": "10 um",
                    "height": "10 um",
                }
            },
            "targets": [
                {"volume": f"det{k}", "rough": [{"face": f, "surface": "pyr"} for f in faces]}
                for k in range(args.crystals)
            ],
            "source": {
                "surface": {"volume": "det0", "face": "+x"},
                "particle": "alpha",
                "energy": "5 MeV",
            },
            "run": {"events": 10, "seed": 1},
        }
        (folder / "tower.yaml").write_text(yaml.safe_dump(config))
        out = folder / "export.gdml"
        t0 = time.perf_counter()
        code = score4(["geometry", "export", str(folder / "tower.yaml"), "--gdml", str(out)])
        wall = time.perf_counter() - t0
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)
        assert code == 0
        print(
            f"{args.crystals} crystals, {len(faces) * args.crystals} rough faces of 10 um "
            f"pyramids ({args.size:g} mm faces)"
        )
        print(f"export: {out.stat().st_size / 1e6:.2f} MB, {wall:.1f} s wall")
        print(
            f"export child processes: {kids.ru_utime + kids.ru_stime:.1f} s CPU, "
            f"peak {kids.ru_maxrss / 1024:.0f} MB resident"
        )
        with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
            w, c, n = pool.submit(_read_geant4, str(out)).result()
        kids2 = resource.getrusage(resource.RUSAGE_CHILDREN)
        print(
            f"Geant4 reads it: {w:.1f} s wall, {c:.1f} s CPU ({n} daughters of the world), "
            f"peak {kids2.ru_maxrss / 1024:.0f} MB resident (largest child so far)"
        )
        import pyg4ometry

        pyg4ometry.config.doMeshing = False
        t0, c0 = time.perf_counter(), time.process_time()
        reg = pyg4ometry.gdml.Reader(str(out)).getRegistry()
        print(
            f"pyg4ometry reads it: {time.perf_counter() - t0:.1f} s wall, "
            f"{time.process_time() - c0:.1f} s CPU, {len(reg.physicalVolumeDict)} physical "
            f"volumes, peak {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB "
            "resident (this process)"
        )
    sys.stdout.flush()


if __name__ == "__main__":
    main()
