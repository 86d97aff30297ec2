"""The fast TRIM replay walk against the previous one (``helpers.replay_reference``).

Both walks replay the same Pb-206 recoils of Po-210 decays 20 nm (mean) under a flat and a
pyramid Si face, from the same libraries and random streams. The fast walk may differ in the
last bits (other arithmetic order, fewer navigator calls), so it must agree statistically:
escape fractions within 0.01, and the two-sample Kolmogorov-Smirnov distance of the deposits
in the crystal, of the escaped energies and of the stop depths below the 1 % critical value.
With the same draws the recoils must also agree one by one (deposits within 1e-9 relative, end
points within 1e-9 mm, 1e-6 mm for those that fly 11 mm to the world's edge) for at least
99 % of them: a rounding may only decide a boundary crossing differently now and then.
Geant4 runs in spawned processes.
"""

from __future__ import annotations

import numpy as np
import pytest

from helpers.spawn import run_in_spawned_process

pytest.importorskip("lunasrim")
pytestmark = pytest.mark.xdist_group("heavy-ions")


def _call(rough: bool, events: int):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers import g4_heavy_ions

    return g4_heavy_ions.replay_pairs(rough, events)


def _ks_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest gap between the empirical distribution functions of ``a`` and ``b``."""
    grid = np.sort(np.concatenate([a, b]))
    fa = np.searchsorted(np.sort(a), grid, side="right") / len(a)
    fb = np.searchsorted(np.sort(b), grid, side="right") / len(b)
    return float(np.abs(fa - fb).max())


@pytest.mark.parametrize(("rough", "events"), [(False, 2000), (True, 1000)])
def test_fast_replay_agrees_with_the_previous_walk(rough, events):
    out = run_in_spawned_process(_call, rough, events)
    fast, ref = out["fast"], out["reference"]
    n = len(ref["escaped"])
    assert n == events  # one recoil per decay
    # energy is conserved by both: deposits + escaped = the recoil's energy
    for walk in (fast, ref):
        assert np.allclose(walk["deposits"].sum(axis=1) + walk["escaped"], out["energy"])
    # statistically
    escaped_fast, escaped_ref = fast["escaped"] > 0, ref["escaped"] > 0
    assert 0.05 < escaped_ref.mean() < 0.5  # the set-up lets a good part of them out
    assert abs(escaped_fast.mean() - escaped_ref.mean()) < 0.01
    critical = 1.63 * np.sqrt(2 / n)  # two samples of n, 1 % level
    stopped_fast, stopped_ref = ~escaped_fast, ~escaped_ref
    pairs = [
        (fast["deposits"][:, 0], ref["deposits"][:, 0]),
        (fast["escaped"][escaped_fast], ref["escaped"][escaped_ref]),
        (fast["end"][stopped_fast, 2], ref["end"][stopped_ref, 2]),  # stop depths
    ]
    for a, b in pairs:
        assert _ks_distance(a, b) < critical
    # recoil by recoil
    same = (
        np.isclose(fast["deposits"], ref["deposits"], rtol=1e-9, atol=1e-12).all(axis=1)
        & np.isclose(fast["escaped"], ref["escaped"], rtol=1e-9, atol=1e-12)
        & (np.abs(fast["end"] - ref["end"]).max(axis=1) < np.where(escaped_ref, 1e-6, 1e-9))
    )
    assert same.mean() >= 0.99
