import numpy as np

from helpers.spawn import run_in_spawned_process


def test_two_primaries_per_event_are_tracked_together():
    edep = np.array(run_in_spawned_process(_run, 20))
    # The alpha stops in the crystal (5.304 MeV); the recoil, 1 um deep and heading up, also
    # stops inside (lite range 283 nm < 1 um): every event deposits the sum of both.
    assert edep.shape == (20,)
    assert np.allclose(edep, 5.304 + 0.103, atol=1e-6)


def _run(n):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_multi_primary import po210_like_events

    return po210_like_events(n)
