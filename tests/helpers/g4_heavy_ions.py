"""Run in spawned processes by test_heavy_ions: Geant4 must not be imported by pytest itself."""

from __future__ import annotations

import numpy as np

from score4.runner.run_plan import plan_run


def ranges(cases, events, seed, histories, materials=None, alphas="geant4"):
    """simulate_ranges for ``cases`` (tuples of RangeCase arguments); plain arrays per case."""
    from score4.sim.range_run import RangeCase, simulate_ranges

    results = simulate_ranges(
        [RangeCase(*c) for c in cases],
        events,
        seed,
        materials=materials,
        physics="lite",
        histories=histories,
        alphas=alphas,
    )
    return [(vars(sample), composition) for sample, composition in results]


def run_config(data: dict, seed: int):
    """Sample and track the events of a config dict; primaries, scores, end points, volumes."""
    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    config = parse_config(data)
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")))
    primaries = sim.source.primaries(np.random.default_rng(seed), 0, config.run.events)
    scores = sim.run(primaries, seed, endpoints=True)
    return {
        "particle": primaries.particle,
        "event": primaries.event,
        "energy": primaries.energy,
        "position": primaries.position,
        "direction": primaries.direction,
        "depth": primaries.extra.get("depth"),
        "endpoints": sim.endpoints,
        "edep": scores["edep"],
        "volumes": sim.volumes,
        "library_seed": sim.heavy_ions.library_seed if sim.heavy_ions else None,
    }


def two_layers(gap_nm: float, events: int):
    """103 keV Pb-206 along -z into a 20 nm Si layer on a Si block, ``gap_nm`` apart."""
    data = {
        "physics": {"mode": "lite", "trim_histories": 300},
        "targets": [
            {
                "name": "block",
                "material": "G4_Si",
                "size": ["1 mm", "1 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
            },
            {
                "name": "layer",
                "material": "G4_Si",
                "size": ["1 mm", "1 mm", "20 nm"],
                "position": ["0 mm", "0 mm", f"{gap_nm + 10} nm"],
            },
        ],
        "source": {
            "particle": "Pb206",
            "energy": "103.144 keV",
            "direction": "normal",
            "surface": {"volume": "layer", "face": "+z"},
        },
        "run": {"events": events, "seed": 3},
    }
    return run_config(data, 3)


def po210(rough: bool, events: int):
    """Po-210 (alpha + Pb-206 recoil) 20 nm (mean, exponential) under a Si face."""
    return run_config(po210_config(rough, events), 5)


def po210_config(rough: bool, events: int) -> dict:
    """The config dict of :func:`po210` (pyramids on the face with ``rough``)."""
    data = {
        "physics": {"mode": "lite"},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["2 mm", "2 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
            }
        ],
        "source": {
            "decay": "Po210",
            "direction": "isotropic",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
        "run": {"events": events, "seed": 5},
    }
    if rough:
        data["surfaces"] = {
            "pyramids": {"kind": "spikes", "nx": 20, "ny": 20, "width": "10 um", "height": "10 um"}
        }
        data["targets"][0]["rough"] = [
            {"face": "+z", "surface": "pyramids", "base_thickness": "1 um"}
        ]
    return data


def pushed_recoils(events: int):
    """Protons (5 MeV, normal) into Si; a 103.144 keV Pb-206 is pushed onto Geant4's stack as a
    secondary at the proton's third step of every event (a heavy-ion secondary made without
    data sets). Runs the same events without the push, with it, and with it and the stable
    ions sent back to Geant4 where they stopped (the re-injection that lets unstable ions
    decay); returns deposits, the intercepted ions and where Geant4 then starts Pb-206 tracks."""
    import ctypes

    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    data = {
        "physics": {"mode": "lite", "trim_histories": 200},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["2 mm", "2 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
            }
        ],
        "source": {
            "particle": "proton",
            "energy": "5 MeV",
            "direction": "normal",
            "surface": {"volume": "crystal", "face": "+z"},
        },
        "run": {"events": events, "seed": 4},
    }
    sim = Simulation(plan_run(parse_config(data), physics=resolve_physics("lite")))
    g4 = sim.g4
    lead = sim.particle("Pb206")
    push = [False]

    class Push(g4.G4UserSteppingAction):
        def UserSteppingAction(self, step):
            track = step.GetTrack()
            if push[0] and track.GetTrackID() == 1 and track.GetCurrentStepNumber() == 3:
                p = step.GetPostStepPoint().GetPosition()
                particle = g4.G4DynamicParticle(
                    lead, g4.G4ThreeVector(0.0, 0.6, 0.8), 0.103144, 0.0
                )
                ion = g4.G4Track(particle, 0.0, g4.G4ThreeVector(p.x, p.y, p.z))
                ion.SetParentID(1)
                for obj in (particle, ion):  # Geant4 deletes them: Python must never do so
                    ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))
                g4.G4EventManager.GetEventManager().GetStackManager().PushOneTrack(ion)

    starts = []

    class Starts(g4.G4UserTrackingAction):
        def PreUserTrackingAction(self, track):
            if track.GetDefinition().GetParticleName() == "Pb206":
                q = track.GetPosition()
                starts.append((q.x, q.y, q.z, track.GetKineticEnergy()))

    actions = [Push(), Starts()]
    for action in actions:
        sim.run_manager.SetUserAction(action)
    primaries = sim.source.primaries(np.random.default_rng(4), 0, events)
    plain = sim.run(primaries, 4)["edep"][:, 0].copy()
    push[0] = True
    pushed = sim.run(primaries, 4)["edep"][:, 0].copy()
    first = [
        (
            x.event,
            x.ion,
            x.energy,
            x.fate.position,
            x.fate.volume,
            x.fate.material,
            sum(x.fate.deposits.values()),
            x.fate.escaped_energy,
            x.reinjected,
        )
        for x in sim.intercepted
    ]
    sim._interceptor.reinject_stable = True
    again = sim.run(primaries, 4)["edep"][:, 0].copy()
    second = [(x.fate.position, x.reinjected) for x in sim.intercepted]
    return {
        "plain": plain,
        "pushed": pushed,
        "again": again,
        "first": first,
        "second": second,
        "starts": np.array(starts).reshape(-1, 4),
    }


def pushed_recoil_steps(events: int):
    """Protons (5 MeV, normal) into Si with steps recorded; at the end of each proton's track a
    103.144 keV Pb-206 is pushed onto Geant4's stack there, at the proton's global time. Returns
    the step table and the time of each push (ns)."""
    import ctypes

    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    data = {
        "physics": {"mode": "lite", "trim_histories": 200},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["2 mm", "2 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
            }
        ],
        "source": {
            "particle": "proton",
            "energy": "5 MeV",
            "direction": "normal",
            "surface": {"volume": "crystal", "face": "+z"},
        },
        "run": {"events": events, "seed": 4},
        "output": {"steps": True},
    }
    sim = Simulation(plan_run(parse_config(data), physics=resolve_physics("lite")))
    g4 = sim.g4
    lead = sim.particle("Pb206")
    times = []

    class Push(g4.G4UserTrackingAction):  # the stepping action records the steps
        def PostUserTrackingAction(self, track):
            if track.GetTrackID() != 1:
                return
            p, t = track.GetPosition(), track.GetGlobalTime()
            particle = g4.G4DynamicParticle(lead, g4.G4ThreeVector(0.0, 0.6, -0.8), 0.103144, 0.0)
            ion = g4.G4Track(particle, t, g4.G4ThreeVector(p.x, p.y, p.z))
            ion.SetParentID(1)
            for obj in (particle, ion):  # Geant4 deletes them: Python must never do so
                ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))
            g4.G4EventManager.GetEventManager().GetStackManager().PushOneTrack(ion)
            times.append(t)

    action = Push()
    sim.run_manager.SetUserAction(action)
    primaries = sim.source.primaries(np.random.default_rng(4), 0, events)
    sim.run(primaries, 4)
    steps = {k: np.asarray(v) for k, v in (sim.last_steps or {}).items()}
    return {"steps": steps, "times": np.array(times), "intercepted": len(sim.intercepted)}


def nuclide_recoils(nuclide: str, events: int):
    """``nuclide`` at rest 20 nm under a Si face, full physics with radioactive decay (needs the
    Geant4 data sets); (event, ion, energy MeV, reinjected) of every intercepted ion."""
    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    data = {
        "physics": {"mode": "full"},
        "targets": [
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["2 mm", "2 mm", "1 mm"],
                "position": ["0 mm", "0 mm", "-0.5 mm"],
            }
        ],
        "source": {
            "nuclide": nuclide,
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "uniform", "max": "20 nm"},
        },
        "run": {"events": events, "seed": 5},
    }
    sim = Simulation(
        plan_run(parse_config(data), physics=resolve_physics("full", needs_decay=True))
    )
    primaries = sim.source.primaries(np.random.default_rng(5), 0, events)
    sim.run(primaries, 5)
    return [(x.event, x.ion, x.energy, x.reinjected) for x in sim.intercepted]


def range_with_reference(seed: int, events: int):
    """``score4 range Pb206 "103.144 keV" G4_Si --compare-srim`` as the command runs it: the
    stopped depths (nm) of score4 and of its TRIM reference, and the reference's TRIM seed."""
    from score4.cli.range_cmd import run_range
    from score4.ions.species import parse_ion

    result = run_range(
        parse_ion("Pb206", "ION"),
        0.103144,
        "G4_Si",
        events,
        seed,
        None,
        0.0,
        {},
        events,
        lambda message: None,
    )
    ours, ref = result["_score4_sample"], result["_srim_sample"]
    return (
        ours.final_position[ours.stopped, 2] * 1e6,
        ref.final_position[ref.stopped, 2] * 1e6,
        result["srim"]["trim_seed"],
    )


def alpha_depths(spec: dict):
    """benchmarks/bench_alpha_straggling.py's measurement of one Geant4 set-up (see there)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_alpha_straggling import measure

    return measure(spec)


def replay_pairs(rough: bool, events: int, seed: int = 5):
    """The Pb-206 recoils of ``events`` Po-210 decays (the :func:`po210` set-up) replayed twice
    from the same random streams and libraries: by score4's walk and by the previous one
    (``helpers.replay_reference``). Per recoil and walk: deposit per scoring column (MeV),
    escaped energy (MeV), end point (mm) and boundaries crossed."""
    from score4.inputs.config import parse_config
    from score4.sim.heavy_ions import ReplayStream
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    from .replay_reference import ReferenceTransport

    data = po210_config(rough, events)
    sim = Simulation(plan_run(parse_config(data), physics=resolve_physics("lite")))
    fast = sim.heavy_ions
    assert fast is not None
    reference = ReferenceTransport(
        sim.g4, sim.geometry.world, sim.geometry.scoring, fast.histories, fast.library_seed
    )
    reference._libraries = fast._libraries  # the same libraries (they are read once)
    primaries = sim.source.primaries(np.random.default_rng(seed), 0, events)
    particle = sim.particle("Pb206")
    rows = np.flatnonzero(primaries.particle == "Pb206")
    out = {}
    for name, transport in (("fast", fast), ("reference", reference)):
        deposits = np.zeros((len(rows), len(sim.volumes)))
        escaped, ends, crossings = (
            np.zeros(len(rows)),
            np.zeros((len(rows), 3)),
            np.zeros(len(rows)),
        )
        for n, r in enumerate(rows.tolist()):
            fate = transport.transport(
                particle,
                "Pb206",
                float(primaries.energy[r]),
                primaries.position[r],
                primaries.direction[r],
                ReplayStream(seed, 1, r),
            )
            for volume, value in fate.deposits.items():
                deposits[n, volume] += value
            escaped[n], ends[n], crossings[n] = fate.escaped_energy, fate.position, fate.crossings
        out[name] = {"deposits": deposits, "escaped": escaped, "end": ends, "crossings": crossings}
    out["energy"] = primaries.energy[rows]
    out["position"] = primaries.position[rows]
    return out
