"""Run in a spawned process by test_multi_primary: Geant4 must not be imported by pytest itself."""

import numpy as np


def po210_like_events(n: int) -> list[float]:
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation
    from score4.source.primaries import Primaries

    from conftest import config_dict

    config = parse_config(config_dict(physics={"mode": "lite", "production_cut": "0.7 mm"}))
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")))
    # Two primaries per event from one vertex 1 um deep: an alpha down, a Pb-206 recoil up.
    z = -1e-3
    primaries = Primaries(
        event=np.repeat(np.arange(n), 2),
        particle=np.tile(["alpha", "Pb206"], n),
        energy=np.tile([5.304, 0.103], n),
        position=np.tile([0.0, 0.0, z], (2 * n, 1)),
        direction=np.tile([[0, 0, -1.0], [0, 0, 1.0]], (n, 1)),
    )
    return sim.run(primaries, 3)["edep"][:, 0].tolist()
