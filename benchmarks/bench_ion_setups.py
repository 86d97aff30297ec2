"""Does any Geant4 set-up reachable through geant4_pybind range ions like TRIM? (issue 10, item 2)

A stand-alone Geant4 application per set-up, each in its own subprocess (Geant4 state is global):
one box of material (1 mm thick, semi-infinite for these ions) in a vacuum world, ions at normal
incidence starting 1 nm above its surface, a Python tracking action recording where the primary
ends; serial run manager; score4's lite data stub (no Geant4 data sets); eBrem and
GammaGeneralProc removed after ``Initialize()`` as ``score4.sim.physics`` does. Set-ups differ by
EM constructor, ``G4EmParameters`` setters, UI commands, production cut and step limits. The
reference is TRIM (SRIM-2013 via the PyPI package ``lunasrim``) for the same ion, energy and
target composition, cached in ``~/.cache/score4/bench_ion_setups_trim.json``.

Usage::

    python benchmarks/bench_ion_setups.py          # Pb206 103.144 keV in G4_Si, all set-ups
    python benchmarks/bench_ion_setups.py --ion alpha --energy 5300 --events 200
    python benchmarks/bench_ion_setups.py --material TeO2 --setups lite,msc_off,ss
    python benchmarks/bench_ion_setups.py --matrix # key set-ups x 6 materials x 3 energies
    python benchmarks/bench_ion_setups.py --matrix --energy 103.144 --setups lite_before

Columns: mean projected depth of the ions that stop in the target, longitudinal straggling (sigma
of that depth), lateral straggling (rms of one transverse coordinate), backscattered fraction,
steps of the primary per ion, CPU per ion (process time of ``BeamOn`` / ions; includes the Python
tracking action, a few us; the machine is shared, so CPU figures are noisy: compare them within one
run). Ratios are Geant4 / TRIM. Tolerances (issue 10): Pb-206 depth within 10 %, straggling within
30 %; alpha depth within 3 %.

This docstring says what the script measures; what it measured (tables of past runs, with
date and load) is in benchmarks/README.md, section bench_ion_setups.py.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# Target materials: Geant4 name -> (TRIM target formula, density g/cm3). TeO2 is not a NIST
# material: built from elements with the density of CUORE's crystals.
MATERIALS = {
    "G4_Si": ("Si", 2.33),
    "G4_Ge": ("Ge", 5.323),
    "G4_Cu": ("Cu", 8.96),
    "G4_CALCIUM_TUNGSTATE": ("CaWO4", 6.062),
    "G4_SODIUM_IODIDE": ("NaI", 3.667),
    "TeO2": ("TeO2", 6.02),
}
IONS = {"Pb206": (82, 206, "Pb"), "alpha": (2, 4, "He")}
ION_ENERGIES_KEV = {"Pb206": (50.0, 103.144, 200.0), "alpha": (1000.0, 3000.0, 5300.0)}
TOLERANCE = {"Pb206": (0.10, 0.30), "alpha": (0.03, None)}  # depth, straggling (relative)

# name -> description of the set-up (keys read by run_setup):
#   physics: EM constructor; niel: SetMaxNIELEnergy (MeV) after it, None = constructor default;
#   cut_um: /run/setCut; params: [(G4EmParameters setter, args)]; pre/post: UI commands before /
#   after Initialize; msc_off: /process/inactivate the msc of the ion; max_step_nm: G4UserLimits
#   on the target + G4StepLimiterPhysics; fluo_off: SetFluo(False) (option3/4, Livermore...).
SETUPS: dict[str, dict] = {
    "lite_before": {"niel": 1.0, "note": "score4 lite until 2026-11: option0, NIEL 1 MeV, 1 um"},
    "lite": {
        "niel": 0.0,
        "params": [("SetStepFunctionLightIons", (0.05, 1e-4))],
        "note": "score4 lite now: option0, no nuclear stopping, light-ion step function, 1 um cut",
    },
    "lite_niel0": {"niel": 0.0, "note": "option0, no nuclear stopping, 1 um cut"},
    "cut_0.7mm": {"niel": 1.0, "cut_um": 700.0},
    "msc_off": {"niel": 1.0, "msc_off": True},
    "msc_off_niel0": {"niel": 0.0, "msc_off": True},
    "stepfn_ions_0.01_1nm": {"niel": 1.0, "params": [("SetStepFunctionIons", (0.01, 1e-6))]},
    "stepfn_ions_0.01_1nm_msc_off": {
        "niel": 1.0,
        "msc_off": True,
        "params": [("SetStepFunctionIons", (0.01, 1e-6))],
    },
    "stepfn_ions_0.001_0.1nm_msc_off": {
        "niel": 1.0,
        "msc_off": True,
        "params": [("SetStepFunctionIons", (0.001, 1e-7))],
    },
    "stepfn_ions_0.01_1nm_rf_0.001": {
        "niel": 1.0,
        "params": [("SetStepFunctionIons", (0.01, 1e-6)), ("SetMscMuHadRangeFactor", (0.001,))],
    },
    "stepfn_light_0.01_1nm": {"niel": 1.0, "params": [("SetStepFunctionLightIons", (0.01, 1e-6))]},
    "stepfn_light_0.1_1um": {"niel": 0.0, "params": [("SetStepFunctionLightIons", (0.1, 1e-3))]},
    "stepfn_light_0.05_0.1um": {
        "niel": 0.0,
        "params": [("SetStepFunctionLightIons", (0.05, 1e-4))],
    },
    "ui_stepfn_ions": {"niel": 1.0, "pre": ["/process/eLoss/StepFunctionIons 0.01 1 nm"]},
    "lowest_muhad_10eV": {"niel": 1.0, "params": [("SetLowestMuHadEnergy", (1e-5,))]},
    "ui_lowest_muhad_10eV": {"niel": 1.0, "pre": ["/process/em/lowestMuHadEnergy 10 eV"]},
    # G4MscStepLimitType is not bound, so SetMscMuHadStepLimitType cannot be called: UI commands
    "ui_msc_muhad_minimal": {"niel": 1.0, "pre": ["/process/msc/StepLimitMuHad Minimal"]},
    "ui_msc_muhad_distance": {
        "niel": 1.0,
        "pre": ["/process/msc/StepLimitMuHad UseDistanceToBoundary"],
    },
    "ui_msc_muhad_safetyplus": {"niel": 1.0, "pre": ["/process/msc/StepLimitMuHad UseSafetyPlus"]},
    "msc_muhad_rf_0.001": {"niel": 1.0, "params": [("SetMscMuHadRangeFactor", (0.001,))]},
    "ui_msc_muhad_rf_0.001": {"niel": 1.0, "pre": ["/process/msc/RangeFactorMuHad 0.001"]},
    "msc_muhad_lateral_on": {"niel": 1.0, "params": [("SetMuHadLateralDisplacement", (True,))]},
    "max_step_1nm": {"niel": 1.0, "max_step_nm": 1.0},
    "max_step_1nm_msc_off": {"niel": 1.0, "max_step_nm": 1.0, "msc_off": True},
    "option1": {"physics": "G4EmStandardPhysics_option1", "niel": 1.0},
    "option2": {"physics": "G4EmStandardPhysics_option2", "niel": 1.0},
    "option3": {"physics": "G4EmStandardPhysics_option3", "fluo_off": True},
    "option3_niel0": {"physics": "G4EmStandardPhysics_option3", "fluo_off": True, "niel": 0.0},
    "option4": {"physics": "G4EmStandardPhysics_option4", "fluo_off": True},
    "ss": {"physics": "G4EmStandardPhysicsSS"},
    "wvi": {"physics": "G4EmStandardPhysicsWVI", "niel": 1.0},
    "gs": {"physics": "G4EmStandardPhysicsGS", "niel": 1.0},
    "livermore": {"physics": "G4EmLivermorePhysics", "fluo_off": True},
    "penelope": {"physics": "G4EmPenelopePhysics", "fluo_off": True},
    "lowep": {"physics": "G4EmLowEPPhysics", "fluo_off": True},
}
MATRIX_SETUPS = (
    "lite",
    "lite_niel0",
    "lite_before",
    "msc_off",
    "stepfn_ions_0.01_1nm_msc_off",
    "msc_muhad_rf_0.001",
    "max_step_1nm",
)


# ----------------------------------------------------------------------------------------------
# One set-up in this process (the subprocess side)


def run_setup(spec: dict) -> dict:
    """Track ``spec['events']`` ions with set-up ``spec`` in this process; return the figures."""
    from score4.sim.physics import strip_data_hungry_processes
    from score4.sim.runtime import PhysicsChoice, prepare_environment

    prepare_environment(PhysicsChoice("lite", "lite", False, "", ()))
    import geant4_pybind as g4

    setup = SETUPS[spec["setup"]]
    z_ion, a_ion, _ = IONS[spec["ion"]]
    thickness = 1.0  # mm
    rm = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
    ui = g4.G4UImanager.GetUIpointer()
    for cmd in ("/control/verbose 0", "/run/verbose 0", "/event/verbose 0", "/tracking/verbose 0"):
        ui.ApplyCommand(cmd)
    keep = []

    def material(name):
        nist = g4.G4NistManager.Instance()
        if name != "TeO2":
            return nist.FindOrBuildMaterial(name)
        mat = g4.G4Material("TeO2", MATERIALS["TeO2"][1] * g4.g / g4.cm3, 2)
        mat.AddElement(nist.FindOrBuildElement("Te"), 1)
        mat.AddElement(nist.FindOrBuildElement("O"), 2)
        return mat

    class Detector(g4.G4VUserDetectorConstruction):
        def Construct(self):
            ws = g4.G4Box("World", 5.0, 5.0, 5.0)
            wl = g4.G4LogicalVolume(
                ws, g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Galactic"), "World"
            )
            wp = g4.G4PVPlacement(None, g4.G4ThreeVector(), wl, "World", None, False, 0)
            ts = g4.G4Box("Target", 4.0, 4.0, thickness / 2)
            tl = g4.G4LogicalVolume(ts, material(spec["material"]), "Target")
            tp = g4.G4PVPlacement(
                None, g4.G4ThreeVector(0, 0, -thickness / 2), tl, "Target", wl, False, 0
            )
            if setup.get("max_step_nm"):
                limits = g4.G4UserLimits(setup["max_step_nm"] * 1e-6)
                tl.SetUserLimits(limits)
                keep.append(limits)
            keep.extend([ws, wl, wp, ts, tl, tp])
            return wp

    class Physics(g4.G4VModularPhysicsList):
        def __init__(self):
            super().__init__()
            self.SetVerboseLevel(0)
            self.RegisterPhysics(getattr(g4, setup.get("physics", "G4EmStandardPhysics"))())
            if setup.get("max_step_nm"):
                self.RegisterPhysics(g4.G4StepLimiterPhysics())
            params = g4.G4EmParameters.Instance()
            params.SetVerbose(0)
            if setup.get("niel") is not None:
                params.SetMaxNIELEnergy(setup["niel"] * g4.MeV)
            if setup.get("fluo_off"):
                params.SetFluo(False)
            for method, args in setup.get("params", []):
                getattr(params, method)(*args)

    ends = []

    class Tracking(g4.G4UserTrackingAction):
        def PostUserTrackingAction(self, track):
            if track.GetTrackID() == 1:
                p = track.GetPosition()
                ends.append((p.x, p.y, p.z, track.GetCurrentStepNumber()))

    class Generator(g4.G4VUserPrimaryGeneratorAction):
        def __init__(self):
            super().__init__()
            self.gun = g4.G4ParticleGun(1)
            self.gun.SetParticlePosition(g4.G4ThreeVector(0, 0, 1e-6))
            self.gun.SetParticleMomentumDirection(g4.G4ThreeVector(0, 0, -1))
            self.gun.SetParticleEnergy(spec["energy_kev"] * g4.keV)

        def GeneratePrimaries(self, event):
            self.gun.GeneratePrimaryVertex(event)

    det, phys = Detector(), Physics()
    rm.SetUserInitialization(det)
    rm.SetUserInitialization(phys)
    ui.ApplyCommand(f"/run/setCut {setup.get('cut_um', 1.0)} um")
    for cmd in setup.get("pre", []):  # (ApplyCommand returns None through the binding)
        ui.ApplyCommand(cmd)
    gen, tracking = Generator(), Tracking()
    rm.SetUserAction(gen)
    rm.SetUserAction(tracking)
    rm.Initialize()
    strip_data_hungry_processes(g4)  # lite mode, as score4 runs here
    table = g4.G4ParticleTable.GetParticleTable()
    carrier = "GenericIon" if spec["ion"] != "alpha" else "alpha"
    processes = [
        str(p.GetProcessName())
        for p in table.FindParticle(carrier).GetProcessManager().GetProcessList()
    ]
    if setup.get("msc_off"):
        for name in processes:
            if "msc" in name:
                ui.ApplyCommand(f"/process/inactivate {name} {carrier}")
    for cmd in setup.get("post", []):
        ui.ApplyCommand(cmd)
    manager = table.FindParticle(carrier).GetProcessManager()
    active = [
        str(p.GetProcessName()) for p in manager.GetProcessList() if manager.GetProcessActivation(p)
    ]
    params = g4.G4EmParameters.Instance()
    in_effect = {  # what the setters and UI commands left in G4EmParameters
        "MaxNIELEnergy_MeV": params.MaxNIELEnergy(),
        "LowestMuHadEnergy_MeV": params.LowestMuHadEnergy(),
        "MscMuHadRangeFactor": params.MscMuHadRangeFactor(),
    }
    try:
        in_effect["MscMuHadStepLimitType"] = str(params.MscMuHadStepLimitType())
    except TypeError:  # G4MscStepLimitType is not bound
        in_effect["MscMuHadStepLimitType"] = "(not readable: enum not bound)"
    if spec["ion"] == "alpha":
        gen.gun.SetParticleDefinition(table.FindParticle("alpha"))
    else:
        gen.gun.SetParticleDefinition(g4.G4IonTable.GetIonTable().GetIon(z_ion, a_ion, 0.0))
    rm.BeamOn(0)  # builds the physics tables, so that CPU per ion counts tracking only
    calc = g4.G4EmCalculator()
    target = g4.G4NistManager.Instance().FindOrBuildMaterial(spec["material"])
    target = target or g4.G4Material.GetMaterial("TeO2")
    stopping = [  # (E keV, electronic, nuclear) in keV/nm, as this set-up's models give them
        (
            e,
            calc.ComputeElectronicDEDX(e * g4.keV, gen.gun.GetParticleDefinition(), target)
            * 1e3
            / 1e6,
            calc.ComputeNuclearDEDX(e * g4.keV, gen.gun.GetParticleDefinition(), target)
            * 1e3
            / 1e6,
        )
        for e in stopping_energies(spec["energy_kev"])
    ]
    g4.G4Random.setTheSeed(12345)
    cpu = time.process_time()
    rm.BeamOn(spec["events"])
    cpu = time.process_time() - cpu
    end = np.array(ends)
    inside = end[:, 2] < 0
    depth = -end[inside, 2] * 1e6  # nm
    lateral = end[inside, :2] * 1e6
    return {
        "processes": processes,
        "active_processes": active,
        "parameters": in_effect,
        "n": len(end),
        "depth_nm": float(depth.mean()) if inside.any() else float("nan"),
        "straggling_nm": float(depth.std()) if inside.sum() > 1 else float("nan"),
        "lateral_nm": float(np.sqrt(np.mean(lateral**2))) if inside.any() else float("nan"),
        "backscattered": float(np.mean(~inside)),
        "steps_per_ion": float(end[:, 3].mean()),
        "cpu_us_per_ion": 1e6 * cpu / len(end),
        "stopping_kev_per_nm": stopping,
    }


def stopping_energies(energy_kev: float) -> list[float]:
    """Energies at which stopping powers are compared: the ion's energy and fractions of it."""
    return [energy_kev * f for f in (1.0, 0.5, 0.2, 0.05)]


def run_in_subprocess(spec: dict, timeout: float = 600.0) -> dict:
    """Run one set-up in a fresh Python process; a crash or a Geant4 abort becomes ``error``."""
    cmd = [sys.executable, __file__, "--worker", json.dumps(spec)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout:.0f} s"}
    for line in reversed(done.stdout.splitlines()):
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT ") :])
    text = done.stdout + done.stderr
    lines = [s.strip() for s in text.splitlines() if s.strip()]
    hint = [s for s in lines if "G4Exception" in s or "issued by" in s or "data" in s.lower()]
    why = " | ".join((hint or lines)[-4:])
    return {"error": f"exit {done.returncode}: {why[:400]}"}


# ----------------------------------------------------------------------------------------------
# TRIM reference


def trim_reference(ion: str, energy_kev: float, material: str, ions: int, seed: int = 1) -> dict:
    """Depth, straggling, lateral and backscattered fraction from lunasrim (cached)."""
    cache = Path.home() / ".cache" / "score4" / "bench_ion_setups_trim.json"
    key = f"{ion}|{energy_kev:g}|{material}|{ions}|{seed}|v2"
    store = json.loads(cache.read_text()) if cache.exists() else {}
    if key in store:
        return store[key]
    import shutil

    import lunasrim

    formula, density = MATERIALS[material]
    thickness_nm = 3000.0 if ion != "alpha" else 100000.0
    folder = tempfile.mkdtemp(prefix="score4-trim-")
    try:
        t0 = time.time()
        res = lunasrim.trim(
            IONS[ion][2],
            formula,
            energy=energy_kev,
            thickness=thickness_nm,
            unit="nm",
            ions=ions,
            seed=seed,
            directory=folder,
            density=density,
        )
        x, y, z = (np.asarray(a, dtype=float) / 10.0 for a in res.range3d.positions)  # A -> nm
        table = np.array(
            lunasrim.stopping_table(
                IONS[ion][2],
                formula,
                0.9 * energy_kev / 20,
                1.1 * energy_kev,
                units="keV/um",
                density=density,
            )
        )
        srim_stopping = [
            (
                e,
                float(np.interp(e, table[:, 0], table[:, 1])) / 1e3,
                float(np.interp(e, table[:, 0], table[:, 2])) / 1e3,
            )
            for e in stopping_energies(energy_kev)
        ]
        out = {
            "stopping_kev_per_nm": srim_stopping,
            "depth_nm": float(x.mean()),
            "straggling_nm": float(x.std()),
            "lateral_nm": float(np.sqrt(np.mean((y**2 + z**2) / 2))),
            "backscattered": len(res.backscat) / ions,
            "srim_range_nm": res.range.average_range / 10.0,
            "srim_straggling_nm": res.range.straggling / 10.0,
            "seconds": round(time.time() - t0, 1),
        }
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    store[key] = out
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(store, indent=1))
    return out


# ----------------------------------------------------------------------------------------------
# Tables


def verdict(ion: str, g: dict, ref: dict) -> str:
    tol_depth, tol_strag = TOLERANCE[ion]
    rd = g["depth_nm"] / ref["depth_nm"]
    ok = abs(rd - 1) <= tol_depth
    if tol_strag is not None:
        rs = g["straggling_nm"] / ref["straggling_nm"]
        ok = ok and abs(rs - 1) <= tol_strag
    return "PASS" if ok else "fail"


def print_table(ion: str, energy: float, material: str, rows: dict, ref: dict) -> None:
    unit, scale = ("um", 1e-3) if ion == "alpha" else ("nm", 1.0)
    print(f"\n{ion} {energy:g} keV in {material}  (Geant4 / TRIM ratios; lengths in {unit})")
    print(
        f"{'set-up':30s} {'depth':>9s} {'ratio':>6s} {'sigma':>8s} {'ratio':>6s} {'lateral':>8s} "
        f"{'backsc':>6s} {'steps':>7s} {'cpu_us':>8s}  verdict"
    )
    print(
        f"{'TRIM (lunasrim)':30s} {ref['depth_nm'] * scale:9.4g} {'':6s} "
        f"{ref['straggling_nm'] * scale:8.3g} {'':6s} {ref['lateral_nm'] * scale:8.3g} "
        f"{ref['backscattered']:6.3f}"
    )
    with_nuclear = [
        n for n, g in rows.items() if "error" not in g and g["stopping_kev_per_nm"][0][2]
    ]
    if with_nuclear and "stopping_kev_per_nm" in ref:
        g = rows[with_nuclear[0]]
        print(
            f"stopping powers (keV/nm) at E (keV): Geant4 electronic, nuclear ({with_nuclear[0]}) "
            f"| SRIM electronic, nuclear"
        )
        for (e, se, sn), (_, re_, rn) in zip(
            g["stopping_kev_per_nm"], ref["stopping_kev_per_nm"], strict=False
        ):
            print(f"  {e:9.4g} | {se:8.4f} {sn:8.4f} | {re_:8.4f} {rn:8.4f}")
        # the ratios docs/physics.md quotes, at the ion's own energy (the first row)
        (_, se, sn), (_, re_, rn) = g["stopping_kev_per_nm"][0], ref["stopping_kev_per_nm"][0]
        print(
            f"Geant4 / SRIM stopping of {ion} {energy:g} keV in {material}: "
            f"electronic {se / re_:.2f}, nuclear {sn / rn:.2f}"
        )
    for name, g in rows.items():
        if "error" in g:
            print(f"{name:30s} does not run: {g['error']}")
            continue
        if SETUPS[name].get("msc_off") and any("msc" in p for p in g["active_processes"]):
            print(f"{name:30s} (msc could not be inactivated: {g['active_processes']})")
        print(
            f"{name:30s} {g['depth_nm'] * scale:9.4g} {g['depth_nm'] / ref['depth_nm']:6.3f} "
            f"{g['straggling_nm'] * scale:8.3g} {g['straggling_nm'] / ref['straggling_nm']:6.2f} "
            f"{g['lateral_nm'] * scale:8.3g} {g['backscattered']:6.3f} {g['steps_per_ion']:7.1f} "
            f"{g['cpu_us_per_ion']:8.0f}  {verdict(ion, g, ref)}"
        )
    sys.stdout.flush()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ion", choices=sorted(IONS), default="Pb206")
    ap.add_argument("--energy", type=float, help="keV (default 103.144 for Pb206, 5300 alpha)")
    ap.add_argument("--material", choices=sorted(MATERIALS), default="G4_Si")
    ap.add_argument("--events", type=int, default=200, help="Geant4 ions per set-up")
    ap.add_argument("--trim-ions", type=int, default=500)
    ap.add_argument("--setups", default="all", help="comma-separated names, or 'all'")
    ap.add_argument("--matrix", action="store_true", help="key set-ups x materials x energies")
    ap.add_argument("--json", help="also write all figures to this file")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        print("RESULT " + json.dumps(run_setup(json.loads(args.worker))))
        return
    if args.events <= 0:
        ap.error(f"--events must be > 0, got {args.events}")
    names = list(SETUPS) if args.setups == "all" else args.setups.split(",")
    for name in names:
        if name not in SETUPS:
            ap.error(f"--setups: unknown set-up {name!r}; known: {', '.join(SETUPS)}")
    if args.matrix:
        names = list(MATRIX_SETUPS) if args.setups == "all" else names
        energies = [args.energy] if args.energy else ION_ENERGIES_KEV[args.ion]
        cases = [(args.ion, e, m) for m in MATERIALS for e in energies]
    else:
        energy = args.energy or (5300.0 if args.ion == "alpha" else 103.144)
        if energy <= 0:
            ap.error(f"--energy must be > 0 keV, got {energy}")
        cases = [(args.ion, energy, args.material)]
    everything = []
    for ion, energy, material in cases:
        ref = trim_reference(ion, energy, material, args.trim_ions)
        rows = {}
        for name in names:
            spec = {
                "setup": name,
                "ion": ion,
                "energy_kev": energy,
                "material": material,
                "events": args.events,
            }
            rows[name] = run_in_subprocess(spec)
        print_table(ion, energy, material, rows, ref)
        everything.append(
            {"ion": ion, "energy_kev": energy, "material": material, "trim": ref, "geant4": rows}
        )
    if len(everything) > 1:
        print_ratios(everything)
    if args.json:
        Path(args.json).write_text(json.dumps(everything, indent=1))


def print_ratios(cases: list[dict]) -> None:
    """One line per case: Geant4 / TRIM ratios of depth and straggling for every set-up."""
    names = list(cases[0]["geant4"])
    print("\nGeant4 / TRIM: depth ratio / straggling ratio; TRIM depth +- straggling in nm")
    print(
        f"{'material':22s} {'E keV':>7s} {'TRIM':>15s}  "
        + " ".join(f"{n[:15]:>15s}" for n in names)
    )
    for case in cases:
        t = case["trim"]
        cells = []
        for name in names:
            g = case["geant4"][name]
            if "error" in g:
                cells.append(f"{'does not run':>15s}")
                continue
            rd = g["depth_nm"] / t["depth_nm"]
            rs = g["straggling_nm"] / t["straggling_nm"]
            cells.append(f"{rd:7.3f}/{rs:<7.2f}")
        print(
            f"{case['material']:22s} {case['energy_kev']:7.5g} "
            f"{t['depth_nm']:7.1f}+-{t['straggling_nm']:<6.1f} " + " ".join(cells)
        )
    # the spans docs/physics.md quotes: depth ratios over all cases, per set-up, and the stopping
    # powers at each case's own energy (set-ups with nuclear stopping only)
    for name in names:
        ratios = [
            c["geant4"][name]["depth_nm"] / c["trim"]["depth_nm"]
            for c in cases
            if "error" not in c["geant4"][name]
        ]
        if ratios:
            print(f"{name}: depth / TRIM depth {min(ratios):.3f}-{max(ratios):.3f}")
    electronic, nuclear = [], []
    for case in cases:
        for g in case["geant4"].values():
            if "error" not in g and g["stopping_kev_per_nm"][0][2]:
                (_, se, sn), (_, re_, rn) = (
                    g["stopping_kev_per_nm"][0],
                    case["trim"]["stopping_kev_per_nm"][0],
                )
                electronic.append(se / re_)
                nuclear.append(sn / rn)
                break
    if electronic:
        print(
            f"Geant4 / SRIM stopping at each case's energy: electronic "
            f"{min(electronic):.2f}-{max(electronic):.2f}, "
            f"nuclear {min(nuclear):.2f}-{max(nuclear):.2f}"
        )


if __name__ == "__main__":
    main()
