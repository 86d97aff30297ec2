"""Run in a spawned process by test_portal: a Simulation with given primaries, plus the portal's
counters."""

from __future__ import annotations

import numpy as np

from score4.runner.run_plan import plan_run


def run_primaries(config_data: dict, primaries: dict, g4_seed: int = 3) -> dict:
    """Track ``primaries`` (Primaries fields as arrays) through ``config_data``'s geometry.

    Returns the per-event scores and, for portal tiling, the teleporter's counters.
    """
    from score4.inputs.config import parse_config
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation
    from score4.source.primaries import Primaries

    config = parse_config(config_data)
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")))
    scores = sim.run(Primaries(**primaries), g4_seed)
    out = {q: v.tolist() for q, v in scores.items()}
    out["volumes"] = sim.volumes
    t = sim.teleporter
    if t is not None:
        out.update(
            jumps=t.jumps,
            secondary_jumps=t.secondary_jumps,
            anomalies=t.anomalies,
            left_lab=t.left_lab,
        )
    return out


def as_lists(p) -> dict:
    """Primaries as plain lists, to send to a spawned process."""
    return {
        "event": p.event.tolist(),
        "particle": p.particle.tolist(),
        "energy": p.energy.tolist(),
        "position": np.asarray(p.position).tolist(),
        "direction": np.asarray(p.direction).tolist(),
    }
