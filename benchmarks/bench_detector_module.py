"""Run time of the detector-scale example (examples/detector_module, docs/howto-detector-module.md).

    .venv/bin/python benchmarks/bench_detector_module.py [--events 3000]

Writes the module's GDML (pyg4ometry) in a scratch folder and measures, for po210_1um.yaml:

  build    the whole Geant4 set-up in one process: GDML read, volume model, the crystal's rough
           +x face (60 000 cells of 10 x 10 pyramids, nested native tiling), Geant4 initialisation
  events/s of process CPU over ``--events`` events (Po-210 in the frame, 20 events of warm-up)
  run      the wall time of ``score4 run --jobs 2`` of ``--events`` events (spawning the workers,
           each building the geometry, tracking, merging)

and prints the date and the load (benchmarks/stamp.py): the machine is shared, figures taken
under load are longer than on an idle one.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from score4.runner.run_plan import plan_run

HERE = Path(__file__).resolve().parent
EXAMPLE = HERE.parent / "examples" / "detector_module"


def measure(config_path: str, events: int) -> tuple[float, float]:
    from score4.inputs.config import load_config
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    config = load_config(config_path)
    t0 = time.perf_counter()
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")), log_path=Path(os.devnull))
    build = time.perf_counter() - t0
    sim.run(sim.source.events(1, 0, 20), event_geant4_seeds(1, 0, 20))
    primaries = sim.source.events(1, 20, events)
    c0 = time.process_time()
    sim.run(primaries, event_geant4_seeds(1, 20, events))
    return build, events / (time.process_time() - c0)


def main() -> None:
    from stamp import stamp  # this folder is on sys.path when run as a script

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--events", type=int, default=3000)
    args = ap.parse_args()
    print(stamp())
    with tempfile.TemporaryDirectory(prefix="score4-module-") as tmp:
        folder = Path(tmp)
        subprocess.run(
            [sys.executable, str(EXAMPLE / "write_module.py"), str(folder / "module.gdml")],
            check=True,
            capture_output=True,
        )
        config = folder / "po210_1um.yaml"
        shutil.copy(EXAMPLE / "po210_1um.yaml", config)
        with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
            build, rate = pool.submit(measure, str(config), args.events).result()
        score4 = Path(sys.executable).with_name("score4")
        t0 = time.perf_counter()
        subprocess.run(
            [
                *(str(score4), "run", str(config), "--events", str(args.events), "--jobs", "2"),
                *("--out", str(folder / "run.h5"), "-q"),
            ],
            check=True,
            capture_output=True,
        )
        wall = time.perf_counter() - t0
    print(f"build (GDML, rough face of 60000 cells, Geant4 set-up): {build:.1f} s")
    print(f"tracking: {rate:.0f} events/s of CPU in one process")
    print(f"score4 run --jobs 2, {args.events} events: {wall:.1f} s wall")


if __name__ == "__main__":
    main()
