"""Run in spawned processes by test_heavy_ions: Geant4 must not be imported by pytest itself."""

from __future__ import annotations

import numpy as np


def ranges(cases, events, seed, histories, materials=None):
    """simulate_ranges for ``cases`` (tuples of RangeCase arguments); plain arrays per case."""
    from score4.sim.range_run import RangeCase, simulate_ranges

    results = simulate_ranges(
        [RangeCase(*c) for c in cases],
        events,
        seed,
        materials=materials,
        physics="lite",
        histories=histories,
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
