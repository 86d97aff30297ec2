"""Why Geant4's alpha range straggling in silicon exceeds TRIM's (docs/physics.md#alpha-straggling).

Alphas along the normal into silicon, lite physics, each Geant4 set-up in its own spawned
process (benchmarks/bench_alpha_straggling.py measures them all). TRIM's values: lunasrim,
500 ions, seed 1, from docs/data/srim_reference.csv (tests/test_srim_reference_table.py
recomputes its rows). These tests pin down the measured reason; they do not hide it.
"""

from __future__ import annotations

import pytest

from helpers.spawn import run_in_spawned_process

# TRIM, 5.3 MeV alphas in Si (2.33 g/cm3): projected range and longitudinal straggling, um
TRIM_RANGE_UM, TRIM_STRAGGLING_UM = 26.5872, 0.294397
TRIM = {1.0: (3.48594, 0.177078), 3.0: (12.0387, 0.239665), 5.3: (26.5872, 0.294397)}


def _spawned(spec):
    return run_in_spawned_process(_call, spec)


def _call(spec):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers import g4_heavy_ions

    return g4_heavy_ions.alpha_depths(spec)


def test_energy_loss_fluctuations_in_short_steps_make_the_excess():
    # 300 alphas of 5.3 MeV, seed 7. score4's step function (0.05, 0.1 um) cuts the end of the
    # range into sub-micrometre steps whose sampled losses make the path spread 1.4 um
    # (measured 1.44 with 1000 alphas) and the depth spread ~1.5 x TRIM's; without loss
    # fluctuations the path spreads 0.16 um (delta rays) and the depth as much as TRIM's.
    default = _spawned({"energy": 5.3, "events": 300})
    quiet = _spawned({"energy": 5.3, "events": 300, "params": {"SetLossFluctuations": [False]}})
    assert default["path_sd"] > 1.0
    assert quiet["path_sd"] < 0.3
    assert default["straggling"] > 1.2 * TRIM_STRAGGLING_UM
    assert quiet["straggling"] == pytest.approx(TRIM_STRAGGLING_UM, rel=0.25)
    for r in (default, quiet):  # the mean range is not what differs
        assert r["depth"] == pytest.approx(TRIM_RANGE_UM, rel=0.025)


@pytest.mark.deep
def test_no_step_function_gives_trim_straggling_and_mean_at_all_energies():
    # Geant4's own light-ion step function (0.2, 0.1 mm) brings the 5.3 MeV straggling close
    # to TRIM's but crosses the last micrometres in one straight step: at 1 MeV every alpha
    # stops at the same depth, 18 % beyond TRIM's mean. score4's keeps 1-5.3 MeV means within
    # 3 % (tests/test_heavy_ions.py) with the straggling above. 1000 alphas per case.
    geant4_default = {"params": {"SetStepFunctionLightIons": [0.2, 0.1]}, "events": 1000}
    at1 = _spawned({**geant4_default, "energy": 1.0})
    assert at1["depth"] > 1.1 * TRIM[1.0][0]
    assert at1["straggling"] < 0.01
    at5 = _spawned({**geant4_default, "energy": 5.3})
    assert at5["straggling"] == pytest.approx(TRIM[5.3][1], rel=0.3)
    for energy in (1.0, 3.0, 5.3):
        ours = _spawned({"energy": energy, "events": 1000})
        assert ours["depth"] == pytest.approx(TRIM[energy][0], rel=0.03)
        assert ours["straggling"] > TRIM[energy][1]
