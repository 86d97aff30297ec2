"""Run in spawned processes by test_frustums: Geant4 must not be imported by pytest itself."""

from __future__ import annotations

from score4.runner.run_plan import plan_run


def region_and_deposits(data: dict, seed: int, keep_parallel_region: bool):
    """Is DefaultRegionForParallelWorld in the region store after set-up, and the deposits of
    ``data``'s events (``keep_parallel_region``: skip score4's removal of that region)."""
    import numpy as np

    from score4.inputs.config import parse_config
    from score4.sim import simulation
    from score4.sim.runtime import resolve_physics

    if keep_parallel_region:
        simulation.drop_unused_parallel_world_region = lambda g4: False
    config = parse_config(data)
    sim = simulation.Simulation(plan_run(config, physics=resolve_physics("lite")))
    store = sim.g4.G4RegionStore.GetInstance()
    present = store.GetRegion("DefaultRegionForParallelWorld", False) is not None
    primaries = sim.source.primaries(np.random.default_rng(seed), 0, config.run.events)
    return present, sim.run(primaries, seed)["edep"]
