"""Run in spawned processes by test_heavy_ions: Geant4 must not be imported by pytest itself."""

from __future__ import annotations

import numpy as np


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
    from score4.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    config = parse_config(data)
    sim = Simulation(config, resolve_physics("lite"))
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
    return run_config(data, 5)
