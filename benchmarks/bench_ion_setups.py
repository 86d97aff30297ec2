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

    python benchmarks/bench_ion_setups.py                      # Pb206 103.144 keV in G4_Si, all set-ups
    python benchmarks/bench_ion_setups.py --ion alpha --energy 5300 --events 200
    python benchmarks/bench_ion_setups.py --material TeO2 --setups lite,msc_off,ss
    python benchmarks/bench_ion_setups.py --matrix             # key set-ups x 6 materials x 3 energies
    python benchmarks/bench_ion_setups.py --matrix --energy 103.144 --setups lite_before  # one energy

Columns: mean projected depth of the ions that stop in the target, longitudinal straggling (sigma
of that depth), lateral straggling (rms of one transverse coordinate), backscattered fraction,
steps of the primary per ion, CPU per ion (process time of ``BeamOn`` / ions; includes the Python
tracking action, a few us; the machine is shared, so CPU figures are noisy: compare them within one
run). Ratios are Geant4 / TRIM. Tolerances (issue 10): Pb-206 depth within 10 %, straggling within
30 %; alpha depth within 3 %.

Measured 2026-11-25 (geant4_pybind 0.1.3 = Geant4 11.4.1, lunasrim 1.0.0; 200 Geant4 ions per
set-up (100 for ``stepfn_light_*`` in the alpha matrix), TRIM 500 ions, seed 1; shared machine,
CPU figures noisy). Set-up names are the keys of ``SETUPS``; ``lite`` is score4's set-up now
(no nuclear stopping, light-ion step function 0.05 / 0.1 um), ``lite_before`` the one before
issue 10 (nuclear stopping below 1 MeV, default step functions).

Which constructors start without Geant4 data (ions and alphas only; eBrem/GammaGeneralProc
removed): G4EmStandardPhysics, _option1, _option3 (SetFluo(False)). Abort for lack of G4EMLOW:
_option2 (G4LivermorePhotoElectricModel pe-cs), _option4, Livermore, Penelope (em0006,
G4GoudsmitSaundersonTable::LoadMSCData), SS, WVI, GS (G4ShellData::LoadData: "Please set
G4LEDATA"), LowEP (G4PhotoElectricAngularGeneratorPolarized). So no single-Coulomb-scattering
set-up for ions can run here. _option3 crashed once (signal 11) for alphas in NaI. option1 never
registers nuclearStopping; option0 and option3 register it below SetMaxNIELEnergy (option3's
default 1 MeV), 0 removes it. G4MscStepLimitType is not bound: SetMscMuHadStepLimitType cannot
be called, ``/process/msc/StepLimitMuHad`` works. ``ApplyCommand`` returns None through the
binding; the parameters the commands leave are recorded in ``--json`` (``parameters``).

1. ``python benchmarks/bench_ion_setups.py`` (Pb206 103.144 keV in G4_Si, lengths in nm)::

    set-up                             depth  ratio    sigma  ratio  lateral backsc   steps   cpu_us
    TRIM (lunasrim)                    45.87            9.71            8.04  0.000
    lite_before                        7.185  0.157  0.00212   0.00        0  0.000     2.0       10
    lite                               7.676  0.167     3.44   0.35     4.45  0.020     9.2       17
    cut_0.7mm                          7.185  0.157  0.00212   0.00        0  0.000     2.0       10
    msc_off                            283.4  6.177        0   0.00        0  0.000     2.0       13
    msc_off_niel0                      283.4  6.177        0   0.00        0  0.000     2.0        8
    stepfn_ions_0.01_1nm                6.26  0.136     2.76   0.28     2.93  0.065    10.1       21
    stepfn_ions_0.01_1nm_msc_off       33.46  0.729     1.77   0.18        0  0.000    10.4       16
    stepfn_ions_0.001_0.1nm_msc_off    33.45  0.729     1.68   0.17        0  0.000    95.8       78
    stepfn_ions_0.01_1nm_rf_0.001      7.832  0.171     4.03   0.42     5.08  0.280    94.2      122
    stepfn_light_0.01_1nm              7.185  0.157  0.00212   0.00        0  0.000     2.0       10
    ui_stepfn_ions                      6.26  0.136     2.76   0.28     2.93  0.065    10.1       19
    lowest_muhad_10eV (and ui_)        7.185  0.157  0.00212   0.00        0  0.000     2.0       10
    ui_msc_muhad_minimal               7.185  0.157  0.00212   0.00        0  0.000     2.0        9
    ui_msc_muhad_distance               7.19  0.157  0.00202   0.00        0  0.000     3.0       10
    ui_msc_muhad_safetyplus            7.185  0.157  0.00213   0.00        0  0.000     2.0       10
    msc_muhad_rf_0.001 (and ui_)       16.75  0.365       14   1.44     21.6  0.415    93.3      117
    msc_muhad_lateral_on               7.185  0.157   0.0028   0.00     5.03  0.000     2.0       11
    max_step_1nm                       7.997  0.174     4.52   0.47     5.29  0.215    31.3       49
    max_step_1nm_msc_off               34.04  0.742     1.91   0.20        0  0.000    35.0       35
    option1                            7.676  0.167     3.44   0.35     4.45  0.020     9.2       17
    option3                            7.185  0.157   0.0028   0.00     5.03  0.000     2.0       10
    option3_niel0                      8.758  0.191     14.7   1.52     22.9  0.150     8.3       19
    stopping powers (keV/nm), Geant4 electronic, nuclear | SRIM electronic, nuclear:
      103.1 keV  0.7282 3.3715 | 0.4653 2.8102        20.63 keV  0.3257 2.4581 | 0.2081 1.7846

2. ``--matrix`` (Pb206; depth ratio / straggling ratio, Geant4 / TRIM; ``lite_niel0`` = ``lite``)::

    material               E keV  TRIM nm     lite        lite_before  msc_off      stepfn_ions  msc_rf_0.001 max_step_1nm
                                                                                    _0.01_1nm
                                                                                    _msc_off
    G4_Si                     50  29.3+-6.1   0.103/0.86  0.065/0.00   6.726/0.00   0.684/0.25   0.441/2.24   0.140/0.39
    G4_Si                 103.14  45.9+-9.7   0.167/0.35  0.157/0.00   6.177/0.00   0.729/0.18   0.365/1.44   0.174/0.47
    G4_Si                    200  71.8+-15.9  0.314/0.51  0.324/0.01   5.493/0.00   0.769/0.12   0.380/1.10   0.243/0.51
    G4_Ge                     50  17.4+-6.2   0.070/0.66  0.029/0.00  11.298/0.00   0.738/0.14   0.758/2.05   0.129/0.25
    G4_Ge                 103.14  27.8+-9.8   0.079/0.31  0.065/0.00  10.146/0.00   0.800/0.14   0.510/1.36   0.148/0.26
    G4_Ge                    200  43.9+-15.2  0.144/0.16  0.138/0.00   8.942/0.00   0.858/0.09   0.379/0.94   0.180/0.26
    G4_Cu                     50   9.9+-3.3   0.081/0.92  0.031/0.00  15.927/0.00   0.695/0.26   1.199/3.19   0.167/0.37
    G4_Cu                 103.14  16.1+-5.1   0.098/0.56  0.069/0.00  14.048/0.00   0.796/0.20   0.713/2.02   0.167/0.29
    G4_Cu                    200  24.9+-8.5   0.150/0.14  0.151/0.00  12.633/0.00   0.850/0.14   0.489/1.27   0.222/0.35
    G4_CALCIUM_TUNGSTATE      50  16.2+-6.2   0.061/0.54  0.025/0.00  11.286/0.00   0.762/0.13   0.822/2.07   0.136/0.21
    G4_CALCIUM_TUNGSTATE  103.14  25.6+-9.6   0.063/0.28  0.053/0.00  10.285/0.00   0.833/0.12   0.523/1.25   0.159/0.25
    G4_CALCIUM_TUNGSTATE     200  41.0+-14.0  0.114/0.21  0.104/0.00   8.926/0.00   0.877/0.10   0.375/0.92   0.166/0.26
    G4_SODIUM_IODIDE          50  28.0+-10.9  0.066/0.64  0.023/0.00  10.583/0.00   0.845/0.20   0.838/1.76   0.114/0.18
    G4_SODIUM_IODIDE      103.14  45.3+-17.3  0.052/0.14  0.048/0.00   9.374/0.00   0.862/0.15   0.447/1.07   0.124/0.18
    G4_SODIUM_IODIDE         200  70.4+-26.7  0.105/0.12  0.100/0.00   8.404/0.00   0.914/0.11   0.308/0.74   0.152/0.25
    TeO2                      50  16.4+-6.4   0.071/0.60  0.026/0.00  10.566/0.00   0.778/0.19   0.993/1.83   0.150/0.23
    TeO2                  103.14  26.5+-10.1  0.067/0.22  0.055/0.00   9.375/0.00   0.818/0.15   0.500/1.35   0.140/0.23
    TeO2                     200  42.4+-15.7  0.117/0.10  0.111/0.00   8.176/0.00   0.856/0.09   0.373/0.84   0.169/0.27

   Geant4 / SRIM stopping at the ion's energy: electronic 1.56 (Si), 1.59 (Ge), 1.35 (Cu),
   1.74 (CaWO4), 1.41 (NaI), 1.87 (TeO2); nuclear 1.13-1.30 (all).

3. ``--matrix --ion alpha --setups lite,lite_niel0,lite_before,msc_off,stepfn_light_0.01_1nm``::

    material               E keV  TRIM um       lite        lite_niel0  lite_before msc_off     stepfn_light_0.01_1nm
    G4_Si                   1000   3.49+-0.18   1.022/1.15  1.182/0.00  1.182/0.00  1.188/0.00  1.007/1.44
    G4_Si                   3000  12.04+-0.24   0.994/1.07  1.038/1.09  1.036/1.65  1.042/0.55  0.984/1.41
    G4_Si                   5300  26.59+-0.30   0.983/1.79  1.003/1.57  1.003/1.70  1.005/1.14  0.981/1.52
    G4_Ge                   1000   3.08+-0.26   1.006/0.96  1.154/0.00  1.154/0.00  1.175/0.00  0.968/1.34
    G4_Ge                   3000   9.40+-0.41   0.992/0.94  1.051/0.00  1.051/0.00  1.058/0.00  0.984/0.81
    G4_Ge                   5300  19.16+-0.47   0.994/0.86  1.023/0.38  1.023/0.38  1.027/0.42  0.990/1.12
    G4_Cu                   1000   1.91+-0.21   1.019/0.94  1.232/0.00  1.232/0.00  1.256/0.00  0.992/0.86
    G4_Cu                   3000   5.48+-0.20   0.995/0.95  1.081/0.00  1.081/0.00  1.088/0.00  0.986/1.23
    G4_Cu                   5300  10.96+-0.26   0.989/1.01  1.037/0.00  1.037/0.00  1.038/0.00  0.986/1.23
    G4_CALCIUM_TUNGSTATE    1000   2.42+-0.24   0.940/0.95  1.097/0.00  1.097/0.00  1.120/0.00  0.901/0.85
    G4_CALCIUM_TUNGSTATE    3000   7.59+-0.24   0.969/1.05  1.025/0.00  1.025/0.00  1.034/0.00  0.953/2.02
    G4_CALCIUM_TUNGSTATE    5300  15.98+-0.57   1.006/0.53  1.037/0.00  1.037/0.00  1.040/0.00  1.004/0.49
    G4_SODIUM_IODIDE        1000   4.01+-0.38   1.027/1.10  1.256/0.00  1.256/0.00  1.286/0.00  0.999/1.15
    G4_SODIUM_IODIDE        3000  13.43+-0.52   1.049/0.94  1.120/0.71  1.123/0.39  1.133/0.33  1.031/1.79
    G4_SODIUM_IODIDE        5300  28.46+-1.11   1.057/1.39  1.096/0.48  1.094/0.46  1.104/0.37  1.055/0.85
    TeO2                    1000   2.36+-0.24   0.962/0.81  1.163/0.00  1.163/0.00  1.185/0.00  0.938/0.88
    TeO2                    3000   7.51+-0.29   0.972/0.81  1.040/0.00  1.040/0.00  1.048/0.00  0.961/1.12
    TeO2                    5300  16.08+-0.35   0.986/0.81  1.021/0.00  1.021/0.00  1.023/0.00  0.981/1.04

   Geant4 / SRIM electronic stopping of alphas at 5.3, 2.65, 1.06, 0.265 MeV: Si 1.01 1.03 0.99
   1.00; Ge 1.00 1.02 0.99 1.01; Cu 1.02 1.01 1.01 0.99; CaWO4 0.96 0.98 1.05 1.06; NaI 0.94 0.93
   1.00 0.92; TeO2 0.99 1.01 1.03 1.04. ``python benchmarks/bench_ion_setups.py --ion alpha``
   (5.3 MeV in Si, all set-ups): every set-up that runs is within 3 % (0.978-1.005).

Conclusions:

* Pb-206 (50-200 keV): NO set-up reaches the tolerances in ANY of the six materials. With ion
  msc on, the ion's range from the ionisation tables (electronic only, 283 nm in Si: the step
  limit ignores nuclear stopping) is taken in one or a few steps that msc folds to 2-32 % of
  TRIM's depth with far too little straggling; finer msc steps (range factor 0.001, or a 1 nm
  step limit) give 11-120 % of the depth, straggling 0.2-3.2x, and up to 40 % backscatter in Si
  (TRIM: 0). With msc off and a fine ion step function the ion goes straight: the depth is its
  CSDA path, 0.68-0.91 of TRIM's depth with 0.09-0.26 of its straggling, and no msc set-up can
  exceed that path. The path is short because Geant4's stopping powers for Pb ions are
  1.35-1.87x SRIM's (electronic) and 1.13-1.30x (nuclear). Hence the TRIM-trajectory replay.
* Alphas: ``lite`` (score4 now) is within 3 % of TRIM's depth in Si, Ge and Cu at 1, 3 and 5.3
  MeV; it fails in CaWO4 at 1 and 3 MeV (0.940, 0.969), NaI at 3 and 5.3 MeV (1.049, 1.057)
  and TeO2 at 1 MeV (0.962), where Geant4's alpha stopping differs from SRIM's by 4-8 %: no
  step or msc setting changes that. Geant4's default light-ion step function lets alphas below
  ~1-5 MeV cross their range in one straight step: 10-29 % too deep at 1 MeV (``lite_niel0``).
* Nuclear stopping (``lite_before``) changes Pb-206 depths little (it is folded away with msc on)
  and alphas not at all, and breaks energy conservation (bench_energy_conservation.py): off.
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
            f"{case['material']:22s} {case['energy_kev']:7.5g} {t['depth_nm']:7.1f}+-{t['straggling_nm']:<6.1f} "
            + " ".join(cells)
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
            f"{min(electronic):.2f}-{max(electronic):.2f}, nuclear {min(nuclear):.2f}-{max(nuclear):.2f}"
        )


if __name__ == "__main__":
    main()
