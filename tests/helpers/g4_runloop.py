"""Run in spawned processes by test_runloop: Geant4 must not be imported by pytest itself."""

from __future__ import annotations

import threading

import numpy as np


def _simulation(source: dict | None = None, **sections):
    from score4.inputs.config import parse_config
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation

    from conftest import config_dict

    data = config_dict(**sections)
    if source is not None:  # replaces the alpha source (config_dict would merge it)
        data["source"] = source
    config = parse_config(data)
    return Simulation(plan_run(config, physics=resolve_physics("lite")))


PO210 = {"decay": "Po210", "direction": "isotropic", "surface": {"volume": "crystal", "face": "+z"}}


def kept_events_in_batches(n: int, kept: int) -> dict:
    """Po-210 events (alpha on Geant4, recoil replayed on TRIM and booked to its event): the
    scores and progress of one batch in one BeamOn, then with at most ``kept`` events per
    BeamOn, then a run stopped after 5 events and the batch once more."""
    from score4.errors import RunCancelled
    from score4.runner.seeds import event_geant4_seeds
    from score4.sim import simulation

    sim = _simulation(source=PO210, output={"split_by_particle": True, "track_length": True})
    primaries = sim.source.events(3, 0, n)
    seeds = event_geant4_seeds(3, 0, n)
    out: dict = {"progress": {}}

    def run(name: str) -> None:
        steps: list[int] = []
        scores = sim.run(primaries, seeds, progress=steps.append, batch=4)
        out[name] = {q: a.tolist() for q, a in scores.items()}
        out["progress"][name] = steps

    run("one")
    simulation.KEPT_EVENTS = kept
    run("split")
    stop = threading.Event()

    done = [0]

    def stop_after_5(n_done: int) -> None:  # called at the start of each event after the first
        done[0] += n_done
        if done[0] >= 5:
            stop.set()

    try:
        sim.run(primaries, seeds, progress=stop_after_5, batch=1, stop=stop)
    except RunCancelled as err:
        out["cancelled"] = str(err)
    simulation.KEPT_EVENTS = 10_000
    run("after")
    return out


def idle_particles() -> dict:
    """Which particles an alpha source's and a mu- source's lite set-ups leave without tables,
    a mu- run's deposits, and what a pi+ primary gets on the alpha set-up."""
    from score4.errors import Score4Error
    from score4.source.primaries import Primaries

    out: dict = {}
    sim = _simulation()
    out["alpha"] = sim.idle_particles
    pion = Primaries(
        event=np.array([0]),
        particle=np.array(["pi+"]),
        energy=np.array([10.0]),
        position=np.array([[0.0, 0.0, -1e-3]]),
        direction=np.array([[0.0, 0.0, -1.0]]),
    )
    try:
        sim.run(pion, 1)
    except Score4Error as err:
        out["pion"] = str(err)
    return out


def muon_run() -> dict:
    """A mu- source's idle particles and the deposits of 20 muons of 100 MeV."""
    source = {"particle": "mu-", "energy": "100 MeV", "direction": "normal"}
    sim = _simulation({**source, "surface": {"volume": "crystal", "face": "+z"}})
    scores = sim.run(sim.source.events(1, 0, 20), 1)
    return {"idle": sim.idle_particles, "edep": scores["edep"][:, 0].tolist()}
