"""Cost of the three ways to score energy deposit per volume per event, on alpha events.

    .venv/bin/python benchmarks/bench_scoring.py [--events N]

Each method runs in its own process (one Geant4 application per process) on the same
events: 5.3 MeV alphas from a flat silicon face (lite physics, 1 um production cut).
  mfd       G4MultiFunctionalDetector + G4PSEnergyDeposit, read once per event (score4's choice)
  stepping  a Python G4UserSteppingAction adding each step's deposit to its volume
  sd        a Python G4VSensitiveDetector (ProcessHits per step in the scored volume)
Prints microseconds per event and the mean deposit (all three must agree).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from score4.runner.run_plan import plan_run

CONFIG = {
    "physics": "lite",
    "targets": [
        {
            "name": "crystal",
            "size": ["1 cm", "1 cm", "1 cm"],
            "position": ["0 cm", "0 cm", "-0.5 cm"],
        }
    ],
    "source": {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "crystal"},
    },
}


def measure(method: str, n: int) -> dict:
    from score4.inputs.config import parse_config
    from score4.sim import scoring
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    config = parse_config(CONFIG)
    if method != "mfd":  # replace the C++ scorer by a Python one
        sums: dict = {}

        def attach(self):
            g4: Any = self.g4
            if method == "sd":

                class SD(g4.G4VSensitiveDetector):
                    def ProcessHits(self, step, history):
                        sums["crystal"] = sums.get("crystal", 0.0) + step.GetTotalEnergyDeposit()
                        return True

                sd = SD("py_sd")
                g4.G4SDManager.GetSDMpointer().AddNewDetector(sd)
                for lv in self.groups["crystal"]:
                    lv.SetSensitiveDetector(sd)
                self.detectors.append(sd)

        def read(self, event, out, row):
            out["edep"][row][0] = sums.pop("crystal", 0.0)

        # the scorer's methods replaced on the class (this process runs one method only)
        setattr(scoring.VolumeScorer, "attach", attach)  # noqa: B010
        setattr(scoring.VolumeScorer, "resolve_ids", lambda self: None)  # noqa: B010
        setattr(scoring.VolumeScorer, "read", read)  # noqa: B010
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")), log_path=None)
    if method == "stepping":
        g4: Any = sim.g4
        crystal = sim.geometry.scoring["crystal"][0]

        class Stepping(g4.G4UserSteppingAction):
            def UserSteppingAction(self, step):
                if step.GetPreStepPoint().GetTouchable().GetVolume().GetLogicalVolume() == crystal:
                    sums["crystal"] = sums.get("crystal", 0.0) + step.GetTotalEnergyDeposit()

        stepping = Stepping()  # kept alive: Geant4 holds a pointer only
        sim.run_manager.SetUserAction(stepping)
    primaries = sim.source.primaries(np.random.default_rng(1), 0, n)
    sim.run(primaries, 1, batch=n)  # warm-up (physics tables)
    t0 = time.perf_counter()
    scores = sim.run(primaries, 2, batch=n)
    dt = time.perf_counter() - t0
    return {
        "method": method,
        "us_per_event": 1e6 * dt / n,
        "mean_edep_MeV": float(scores["edep"].mean()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=5000)
    parser.add_argument("--method", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.method:
        import os

        from score4.sim.runtime import redirect_native_output

        with redirect_native_output(Path(os.devnull)):
            result = measure(args.method, args.events)
        print(json.dumps(result))
        return
    print(
        f"{'method':10s} {'us/event':>10s} {'mean edep [MeV]':>16s}   ({args.events} alpha events, "
        "5.3 MeV, flat Si, lite)"
    )
    for method in ("mfd", "stepping", "sd"):
        out = subprocess.run(
            [sys.executable, __file__, "--method", method, "--events", str(args.events)],
            capture_output=True,
            text=True,
            check=True,
        )
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"{r['method']:10s} {r['us_per_event']:10.1f} {r['mean_edep_MeV']:16.5f}")


if __name__ == "__main__":
    main()
