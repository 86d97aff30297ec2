"""Why Geant4 deposited more energy than an event had, step by step (issue 10, item 9).

A stand-alone Geant4 application (score4's lite set-up before issue 10: G4EmStandardPhysics,
1 um cut, default step functions, eBrem and GammaGeneralProc removed; serial; no data sets): a
1 mm silicon block in vacuum, its top face at z = 0; ions start at an exponential depth (mean
20 nm) below it, going outward (upper hemisphere, uniform in cos(theta); ``--isotropic``: all
directions). A Python stepping action records every step; the script counts events whose
deposit in the block exceeds the primary's energy + 1 eV, and prints the steps of the first
violating events, split into ionisation and non-ionising (nuclear stopping) deposits.

Usage::

    python benchmarks/bench_energy_conservation.py            # Pb206 outward, NIEL 1 MeV and 0
    python benchmarks/bench_energy_conservation.py --ion alpha --energy 5300 --events 20000
    python benchmarks/bench_energy_conservation.py --cut 0.7 --niel 1   # no delta electrons

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_energy_conservation.py.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np


def run(args, niel: float) -> None:
    """One configuration in this process (Geant4 state is global: call once per process)."""
    from score4.sim.physics import strip_data_hungry_processes
    from score4.sim.runtime import PhysicsChoice, prepare_environment

    prepare_environment(PhysicsChoice("lite", "lite", False, "", ()))
    import geant4_pybind as g4

    rm = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    ui = g4.G4UImanager.GetUIpointer()
    for cmd in ("/control/verbose 0", "/run/verbose 0", "/event/verbose 0", "/tracking/verbose 0"):
        ui.ApplyCommand(cmd)
    nist = g4.G4NistManager.Instance()
    keep = []

    class Detector(g4.G4VUserDetectorConstruction):
        def Construct(self):
            ws = g4.G4Box("World", 1, 1, 1)
            wl = g4.G4LogicalVolume(ws, nist.FindOrBuildMaterial("G4_Galactic"), "World")
            wp = g4.G4PVPlacement(None, g4.G4ThreeVector(), wl, "World", None, False, 0)
            ts = g4.G4Box("Si", 0.5, 0.5, 0.5)
            tl = g4.G4LogicalVolume(ts, nist.FindOrBuildMaterial("G4_Si"), "Si")
            tp = g4.G4PVPlacement(None, g4.G4ThreeVector(0, 0, -0.5), tl, "Si", wl, False, 0)
            keep.extend([ws, wl, wp, ts, tl, tp])
            return wp

    class Physics(g4.G4VModularPhysicsList):
        def __init__(self):
            super().__init__()
            self.SetVerboseLevel(0)
            self.RegisterPhysics(g4.G4EmStandardPhysics())
            params = g4.G4EmParameters.Instance()
            params.SetVerbose(0)
            params.SetMaxNIELEnergy(niel * g4.MeV)

    rng = np.random.default_rng(args.seed)
    n = args.events
    depth = rng.exponential(args.depth_nm * 1e-6, n)
    cos_t = rng.uniform(0.0 if args.outward else -1.0, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    sin_t = np.sqrt(1 - cos_t**2)
    dirs = np.c_[sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t]
    state = {"event": 0}

    class Generator(g4.G4VUserPrimaryGeneratorAction):
        def __init__(self):
            super().__init__()
            self.gun = g4.G4ParticleGun(1)

        def GeneratePrimaries(self, event):
            k = state["event"]
            self.gun.SetParticleEnergy(args.energy * g4.keV)
            self.gun.SetParticlePosition(g4.G4ThreeVector(0, 0, -depth[k]))
            self.gun.SetParticleMomentumDirection(g4.G4ThreeVector(*dirs[k]))
            self.gun.GeneratePrimaryVertex(event)

    steps = []

    class Stepping(g4.G4UserSteppingAction):
        def UserSteppingAction(self, step):
            pre, post = step.GetPreStepPoint(), step.GetPostStepPoint()
            track = step.GetTrack()
            limiter = post.GetProcessDefinedStep()
            steps.append(
                (
                    state["event"],
                    track.GetTrackID(),
                    str(track.GetDefinition().GetParticleName()),
                    str(pre.GetTouchable().GetVolume().GetName()),
                    pre.GetKineticEnergy(),
                    post.GetKineticEnergy(),
                    step.GetTotalEnergyDeposit(),
                    step.GetNonIonizingEnergyDeposit(),
                    step.GetStepLength(),
                    str(limiter.GetProcessName()) if limiter else "?",
                )
            )

    class Events(g4.G4UserEventAction):
        def EndOfEventAction(self, event):
            state["event"] += 1

    actions: list[Any] = [
        Detector(),
        Physics(),
    ]  # Geant4 wants these set before any user action exists
    rm.SetUserInitialization(actions[0])
    rm.SetUserInitialization(actions[1])
    ui.ApplyCommand(f"/run/setCut {args.cut * 1e3:g} um")
    actions += [Generator(), Stepping(), Events()]
    for a in actions[2:]:
        rm.SetUserAction(a)
    rm.Initialize()
    strip_data_hungry_processes(g4)  # lite mode, as score4 runs here
    table = g4.G4ParticleTable.GetParticleTable()
    ion = args.ion
    definition = (
        table.FindParticle("alpha")
        if ion == "alpha"
        else g4.G4IonTable.GetIonTable().GetIon(*ION_ZA[ion], 0.0)
    )
    actions[2].gun.SetParticleDefinition(definition)
    processes = [str(p.GetProcessName()) for p in definition.GetProcessManager().GetProcessList()]
    g4.G4Random.setTheSeed(args.seed)
    rm.BeamOn(n)
    ev = np.array([s[0] for s in steps])
    in_si = np.array([s[3] == "Si" for s in steps])
    edep = np.array([s[6] for s in steps])
    total = np.bincount(ev, weights=edep * in_si, minlength=n)
    excess = total - args.energy * 1e-3
    bad = np.nonzero(excess > 1e-6)[0]
    say(
        f"{ion} {args.energy:g} keV, NIEL limit {niel:g} MeV, cut {args.cut:g} mm, "
        f"{'outward' if args.outward else 'isotropic'}: {len(bad)} of {n} events deposit more "
        f"than the primary's energy + 1 eV; max excess {max(excess.max(), 0) * 1e3:.4g} keV; "
        f"{len(steps) / n:.1f} steps/event; {ion} processes: {', '.join(processes)}"
    )
    returned = np.count_nonzero([s[3] == "World" and s[8] == 0.0 and s[1] == 1 for s in steps])
    say(
        f"  escaped (deposit < energy - 1 keV): {np.mean(excess < -1e-3):.3f}; zero-length steps "
        f"of the primary in the vacuum (sent straight back into the face): {returned}"
    )
    over = [s for s in steps if s[6] > s[4] + 1e-9]
    say(f"  steps depositing more than their pre-step kinetic energy: {len(over)}")
    for k in bad[: args.show]:
        say(
            f"  event {k}: depth {depth[k] * 1e6:.2f} nm, cos(theta) {dirs[k, 2]:.3f}, "
            f"deposit {total[k] * 1e3:.3f} keV"
        )
        for s in steps:
            if s[0] == k and s[1] == 1:
                say(
                    f"    {s[3]:5s} E_pre {s[4] * 1e3:9.3f}  E_post {s[5] * 1e3:9.3f}  edep "
                    f"{s[6] * 1e3:9.3f} = ionisation {(s[6] - s[7]) * 1e3:8.3f} + non-ionising "
                    f"{s[7] * 1e3:8.3f} keV  step {s[8] * 1e6:8.3g} nm  limited by {s[9]}"
                )


ION_ZA = {"Pb206": (82, 206), "Po210": (84, 210)}
MARK = "@@ "  # prefix of the lines the parent keeps from a run's output (Geant4 prints a lot)


def say(text: str) -> None:
    print(MARK + text, flush=True)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ion", choices=["Pb206", "alpha"], default="Pb206")
    ap.add_argument("--energy", type=float, default=103.144, help="keV")
    ap.add_argument("--events", type=int, default=2000)
    ap.add_argument("--depth-nm", type=float, default=20.0, help="mean of the exponential depth")
    ap.add_argument("--cut", type=float, default=1e-3, help="production cut, mm")
    ap.add_argument("--niel", type=float, action="append", help="MeV; default: 1 and 0")
    ap.add_argument("--isotropic", dest="outward", action="store_false")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--show", type=int, default=2, help="violating events to print")
    ap.add_argument("--one", type=float, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.events <= 0:
        ap.error(f"--events must be > 0, got {args.events}")
    if args.one is not None:
        run(args, args.one)
        return
    import subprocess

    for niel in args.niel or [1.0, 0.0]:  # one process each: Geant4 state is global
        cmd = [sys.executable, __file__, *(argv or sys.argv[1:]), "--one", str(niel)]
        out = subprocess.run(cmd, capture_output=True, text=True, check=False)
        keep = [line[len(MARK) :] for line in out.stdout.splitlines() if line.startswith(MARK)]
        print("\n".join(keep) or out.stderr[-2000:])


if __name__ == "__main__":
    main()
