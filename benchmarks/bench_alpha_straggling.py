"""Why Geant4's alpha range straggling in silicon exceeds TRIM's: settings measured one by one.

Alphas of 1, 3 and 5.3 MeV enter a silicon block along its normal (lite physics, score4's
physics list, 1 um cut); for each Geant4 set-up, in its own process, the primary's end point
gives the projected depth (mean and standard deviation: TRIM's range and longitudinal
straggling) and its track length the true path. TRIM's values are those of
docs/data/srim_reference.csv (lunasrim, 500 ions, seed 1).

    python benchmarks/bench_alpha_straggling.py [--events 1000] [--markdown]

Set-ups: score4's default; G4EmParameters.SetLossFluctuations(False) (global: every particle);
Geant4's own light-ion step function (0.2, 0.1 mm) instead of score4's (0.05, 0.1 um); msc off
for alphas. Tried and left out: SetLowestMuHadEnergy(50 keV) (path spread back to 0.32 um at
5.3 MeV, depth spread still 1.5 x TRIM's, and at 1 MeV some alphas left the block backwards,
mean depth -104 um) and a step function of (0.01, 0.1 um) (the same failure at 5.3 MeV).
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SETUPS: dict[str, dict[str, Any]] = {
    "score4 default": {},
    "loss fluctuations off": {"params": {"SetLossFluctuations": [False]}},
    "Geant4's step function (0.2, 0.1 mm)": {"params": {"SetStepFunctionLightIons": [0.2, 0.1]}},
    "msc off": {"ui": ["/process/inactivate msc alpha"]},
}
ENERGIES = (1.0, 3.0, 5.3)


def measure(spec: dict) -> dict:
    """Depth and path of ``spec["events"]`` alphas (this script run with ``--one SPEC``)."""
    import numpy as np

    from score4.sim import physics
    from score4.sim.runtime import import_geant4, resolve_physics

    choice = resolve_physics("lite")
    g4: Any = import_geant4(choice)

    class Block(g4.G4VUserDetectorConstruction):
        def Construct(self):
            nist = g4.G4NistManager.Instance()
            world = g4.G4Box("world", 1 * g4.m, 1 * g4.m, 1 * g4.m)
            self.world = g4.G4LogicalVolume(world, nist.FindOrBuildMaterial("G4_Galactic"), "w")
            placed = g4.G4PVPlacement(None, g4.G4ThreeVector(), self.world, "w", None, False, 0)
            block = g4.G4Box("block", 0.5 * g4.m, 0.5 * g4.m, 0.5 * g4.m)
            self.block = g4.G4LogicalVolume(block, nist.FindOrBuildMaterial("G4_Si"), "b")
            position = g4.G4ThreeVector(0, 0, 0.5 * g4.m)
            g4.G4PVPlacement(None, position, self.block, "b", self.world, False, 0)
            return placed

    manager = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    keep = [Block(), physics.make_physics_list(g4, choice)]
    for name, args in spec.get("params", {}).items():  # after score4's own settings
        getattr(g4.G4EmParameters.Instance(), name)(*args)
    manager.SetUserInitialization(keep[0])
    manager.SetUserInitialization(keep[1])
    physics.set_production_cut(g4, 1e-3)
    ends, paths = [], []

    class Gun(g4.G4VUserPrimaryGeneratorAction):
        def __init__(self):
            super().__init__()
            self.gun = g4.G4ParticleGun(1)
            self.gun.SetParticleDefinition(g4.G4Alpha.Alpha())
            self.gun.SetParticleEnergy(spec["energy"] * g4.MeV)
            self.gun.SetParticlePosition(g4.G4ThreeVector(0, 0, -1e-7))
            self.gun.SetParticleMomentumDirection(g4.G4ThreeVector(0, 0, 1))

        def GeneratePrimaries(self, event):
            self.gun.GeneratePrimaryVertex(event)

    class Ends(g4.G4UserTrackingAction):
        def PostUserTrackingAction(self, track):
            if track.GetTrackID() == 1:
                ends.append(track.GetPosition().z)
                paths.append(track.GetTrackLength())

    keep += [Gun(), Ends()]
    manager.SetUserAction(keep[2])
    manager.SetUserAction(keep[3])
    manager.Initialize()
    physics.strip_data_hungry_processes(g4)
    for command in spec.get("ui", []):
        g4.G4UImanager.GetUIpointer().ApplyCommand(command)
    g4.G4Random.setTheSeed(spec.get("seed", 7))
    manager.BeamOn(spec["events"])
    depth, path = np.array(ends) * 1e3, np.array(paths) * 1e3  # um
    return {
        "depth": float(depth.mean()),
        "straggling": float(depth.std()),
        "path": float(path.mean()),
        "path_sd": float(path.std()),
    }


def trim_reference() -> dict[float, tuple[float, float]]:
    """{MeV: (TRIM range um, TRIM straggling um)} for alphas in Si, from the reference CSV."""
    lines = (ROOT / "docs/data/srim_reference.csv").read_text().splitlines()
    rows = csv.DictReader(r for r in lines if not r.startswith("#"))
    return {
        float(r["energy_keV"]) / 1e3: (
            float(r["trim_range_nm"]) / 1e3,
            float(r["trim_straggling_nm"]) / 1e3,
        )
        for r in rows
        if r["ion"] == "alpha" and r["material"] == "Si"
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--events", type=int, default=1000)
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(json.loads(args.one))))
        return
    trim = trim_reference()
    print(
        "| Geant4 set-up | energy | depth / TRIM | straggling / TRIM | path um | path sd um |\n"
        "| --- | --- | --- | --- | --- | --- |"
    )
    for name, setup in SETUPS.items():
        for energy in ENERGIES:
            spec = {**setup, "energy": energy, "events": args.events}
            out = (
                subprocess.run(
                    [sys.executable, __file__, "--one", json.dumps(spec)],
                    capture_output=True,
                    text=True,
                    check=True,
                )
                .stdout.strip()
                .splitlines()[-1]
            )
            r = json.loads(out)
            depth, straggling = trim[energy]
            print(
                f"| {name} | {energy:g} MeV | {r['depth'] / depth:.3f} | "
                f"{r['straggling'] / straggling:.2f} | {r['path']:.3f} | {r['path_sd']:.3f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
