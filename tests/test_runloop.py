"""The run loop: scores read after each BeamOn, progress and stop per event, lite tables.

Geant4 keeps the events of a BeamOn and score4 reads their scores when it ends (no Python at
each event's end); a batch larger than ``simulation.KEPT_EVENTS`` runs as several BeamOns. Lite
physics builds no tables for particles nothing creates (``physics.UNCREATED_PARTICLES``).
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.spawn import run_in_spawned_process


def _kept(n: int, kept: int) -> dict:
    from helpers.g4_runloop import kept_events_in_batches

    return kept_events_in_batches(n, kept)


@pytest.fixture(scope="module")
def batches():
    return run_in_spawned_process(_kept, 23, 5, timeout=600)


def test_scores_do_not_depend_on_the_events_per_beamon(batches):
    one, split, after = batches["one"], batches["split"], batches["after"]
    assert set(one) == {"edep", "track_length", "edep_alpha", "edep_electron", "edep_ion"}
    for q in one:  # bit for bit, recoils booked to their events included
        assert np.array_equal(one[q], split[q])
        assert np.array_equal(one[q], after[q])
    edep = np.asarray(one["edep"])[:, 0]
    ion = np.asarray(one["edep_ion"])[:, 0]
    assert (edep > 0).sum() > 10  # alphas
    assert (ion > 0).sum() > 5  # replayed recoils


def test_progress_counts_every_event_once(batches):
    for name in ("one", "split", "after"):  # every 4 events (batch=4), then the rest at the end
        assert batches["progress"][name] == [4, 4, 4, 4, 4, 3]


def test_a_stopped_run_ends_before_its_next_event_and_the_application_runs_on(batches):
    assert batches["cancelled"] == "run cancelled after 5 of 23 events"


def _idle() -> dict:
    from helpers.g4_runloop import idle_particles

    return idle_particles()


def _muons() -> dict:
    from helpers.g4_runloop import muon_run

    return muon_run()


def test_lite_builds_no_tables_for_particles_nothing_creates():
    from score4.sim.physics import UNCREATED_PARTICLES

    out = run_in_spawned_process(_idle, timeout=300)
    assert out["alpha"] == list(UNCREATED_PARTICLES)
    assert out["pion"] == "run: pi+ primaries, but pi+ has no physics processes"


def test_a_source_of_muons_keeps_their_physics():
    out = run_in_spawned_process(_muons, timeout=300)
    assert "mu-" not in out["idle"]
    assert "mu+" in out["idle"]
    # 100 MeV muons along the normal into 1 cm of silicon: ~3.9 MeV each (dE/dx ~ 1.66 MeV cm2/g x
    # 2.33 g/cm3 at minimum ionisation); without their processes they would deposit nothing
    edep = np.asarray(out["edep"])
    assert np.all(edep > 1.0)
    assert np.median(edep) == pytest.approx(3.9, rel=0.25)
