"""Heavy ions created during an event are taken from Geant4 and replayed on TRIM trajectories.

Geant4's radioactive decay (``source.nuclide``) needs data sets absent here, so the lite-mode
test makes such an ion another way: a 103.144 keV Pb-206 pushed onto Geant4's stack as a
secondary during each event of a proton run (``tests/helpers/g4_heavy_ions.py``). Geant4 runs in
spawned processes.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.spawn import run_in_spawned_process

pytest.importorskip("lunasrim")

RECOIL_MEV = 0.103144


def _spawned(function, *args):
    return run_in_spawned_process(_call, function, *args)


def _call(function, *args):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers import g4_heavy_ions

    return getattr(g4_heavy_ions, function)(*args)


@pytest.fixture(scope="module")
def pushed():
    return _spawned("pushed_recoils", 20)


def test_every_heavy_ion_secondary_is_intercepted_and_replayed(pushed):
    first = pushed["first"]
    assert len(first) == 20
    assert [x[0] for x in first] == list(range(20))  # one per event, booked in its own event
    for _event, ion, energy, position, volume, material, deposit, escaped, back in first:
        assert ion == "Pb206"
        assert energy == pytest.approx(RECOIL_MEV, abs=1e-12)
        # it stopped in the silicon, ~1 um below the face: everything deposited there
        assert (volume, material) == ("crystal", "G4_Si")
        assert -5e-3 < position[2] < 0.0
        assert escaped == 0.0
        assert deposit == pytest.approx(RECOIL_MEV, abs=1e-9)
        assert not back  # stable and no radioactive decay: killed after the replay


def test_replayed_deposits_join_the_event(pushed):
    # The pushed ion never reaches Geant4's tracking (no random number drawn for it), so the
    # protons' deposits are the same; each event gains exactly the ion's energy.
    assert np.allclose(pushed["pushed"] - pushed["plain"], RECOIL_MEV, atol=1e-9)
    assert np.array_equal(pushed["again"], pushed["pushed"])


def test_reinjected_ions_start_at_rest_where_trim_stopped_them(pushed):
    # The path unstable ions take in full physics (so that radioactive decay goes on from
    # where they stopped), forced here for stable ones with the test hook reinject_stable.
    second, starts = pushed["second"], pushed["starts"]
    assert all(back for _, back in second)
    assert len(starts) == len(second) == 20
    expected = np.array([position for position, _ in second])
    assert np.allclose(starts[:, :3], expected, atol=1e-12)
    assert (starts[:, 3] == 0.0).all()
    # the same replays as without re-injection (same random streams)
    assert np.allclose(expected, np.array([x[3] for x in pushed["first"]]), atol=0)


def test_nuclide_recoils_in_full_physics():
    from score4.runner import datasets

    missing = datasets.missing_for("full", datasets.status()) + datasets.missing_for(
        "decay", datasets.status()
    )
    if missing:
        pytest.skip(
            "Geant4 radioactive decay needs the data sets "
            + ", ".join(sorted(set(missing)))
            + " (score4 data install --mode full; --mode decay): not installed here"
        )
    r = _spawned("nuclide_recoils", "Po210", 200)
    # every Po-210 decay's Pb-206 recoil (103 keV) was taken from Geant4 and replayed
    recoils = [x for x in r if x[1].startswith("Pb206")]
    assert len(recoils) == 200
    assert all(abs(x[2] - RECOIL_MEV) < 2e-3 for x in recoils)


def test_steps_of_an_intercepted_ion_carry_its_creation_time():
    """A Pb-206 made at the end of each proton's track (its global time, about 0.1 ns in): the
    replayed ion's steps carry that time, the protons' steps Geant4's."""
    out = _spawned("pushed_recoil_steps", 5)
    steps, times = out["steps"], out["times"]
    assert out["intercepted"] == len(times) == 5
    assert (times > 0.01).all()
    lead = steps["particle"] == 1000822060
    assert lead.sum() > 5  # pieces of the replayed paths
    np.testing.assert_array_equal(steps["time"][lead], times[steps["event"][lead]])
    protons = steps["particle"] == 2212
    assert (steps["time"][protons] <= times[steps["event"][protons]] + 1e-12).all()
    assert steps["time"][protons].max() > 0
