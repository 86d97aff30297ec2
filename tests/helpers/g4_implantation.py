"""Run in spawned processes by test_chain_implantation: Geant4 must not be imported by pytest."""

from __future__ import annotations

from pathlib import Path


def implant_chunk(data: dict, atoms: int, seed: int) -> dict:
    """One chunk of ``atoms`` atoms of a config dict, as a worker runs it; plain arrays."""
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation
    from score4.sim.worker import Chunk, WorkerSpec, simulate_chunk

    config = parse_config(data)
    choice = resolve_physics("lite")
    plan = plan_run(config, seed=seed, physics=choice)
    sim = Simulation(plan)
    spec = WorkerSpec(plan, Path("."))
    primaries, scores = simulate_chunk(sim, spec, Chunk(0, 0, atoms))
    return {
        "particle": primaries.particle,
        "event": primaries.event,
        "energy": primaries.energy,
        "position": primaries.position,
        "extra": dict(primaries.extra),
        "edep": scores["edep"],
        "volumes": sim.volumes,
        "counts": sim.run_counts(),
    }
