"""TRIM reference (lunasrim): ion names, RangeSample summaries, TRIM runs, cache, bad input.

TRIM runs here are small (<= 200 ions, about a second each) and cached for the session.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from score4.errors import ConfigError, Score4Error
from score4.ions.composition import Composition
from score4.ions.species import atomic_mass_amu, parse_ion
from score4.ions.srim_reference import (
    RangeSample,
    srim_range_sample,
    stopping_table_reference,
    summarize,
)

SI = Composition.from_formula("G4_Si", "Si", 2.33)
PB_MEV = 0.103144


@pytest.fixture(scope="module", autouse=True)
def _srim_cache(tmp_path_factory):
    """One TRIM cache for the session (shared with test_range_cli), outside the user's cache."""
    import os

    old = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.getbasetemp() / "xdg-cache")
    yield
    if old is None:
        os.environ.pop("XDG_CACHE_HOME", None)
    else:
        os.environ["XDG_CACHE_HOME"] = old


@pytest.mark.parametrize(
    ("name", "z", "a", "canonical"),
    [
        ("Pb206", 82, 206, "Pb206"),
        ("Pb-206", 82, 206, "Pb206"),
        ("206Pb", 82, 206, "Pb206"),
        ("pb206", 82, 206, "Pb206"),
        ("alpha", 2, 4, "alpha"),
        ("He4", 2, 4, "alpha"),
        ("He3", 2, 3, "He3"),
        ("proton", 1, 1, "proton"),
    ],
)
def test_parse_ion(name, z, a, canonical):
    ion = parse_ion(name)
    assert (ion.z, ion.a, ion.name) == (z, a, canonical)


def test_ion_masses_close_to_measured():
    # AME 2020 atomic masses; the mass formula is good to ~0.015 amu for heavy nuclides
    assert atomic_mass_amu(82, 206) == pytest.approx(205.974465, abs=0.01)
    assert atomic_mass_amu(84, 210) == pytest.approx(209.982874, abs=0.01)
    assert atomic_mass_amu(2, 4) == pytest.approx(4.002603, abs=1e-6)


@pytest.mark.parametrize("bad", ["Xx206", "lead", "Pb", "", "alpah", "Pb20600"])
def test_parse_ion_rejects(bad):
    with pytest.raises(ConfigError, match="unknown ion"):
        parse_ion(bad)


def test_parse_ion_suggests_close_names():
    with pytest.raises(ConfigError, match="closest: alpha"):
        parse_ion("alpah")
    with pytest.raises(ConfigError, match="A >= Z"):
        parse_ion("Pb20")


def test_summarize_by_hand():
    pos = np.array([[3, 4, 10], [0, 0, 20], [0, 0, 0], [1, 1, 50]], dtype=float) * 1e-6  # nm
    sample = RangeSample(
        final_position=pos,
        stopped=[True, True, False, False],
        backscattered=[False, False, True, False],
        transmitted=[False, False, False, True],
        exit_energy=[0, 0, 0.01, 0.03],
        deposited=[0.1, 0.1, 0.09, 0.07],
    )
    s = summarize(sample)
    assert s["events"] == 4
    assert s["stopped"] == 2
    assert s["projected_range_nm"] == pytest.approx(15.0)
    assert s["straggling_nm"] == pytest.approx(5.0)  # population standard deviation, as TRIM
    assert s["lateral_nm"] == pytest.approx(math.sqrt((25 + 0) / 2 / 2))
    assert s["backscattered_fraction"] == 0.25
    assert s["transmitted_fraction"] == 0.25
    assert s["mean_exit_energy_keV"] == pytest.approx(30.0)
    assert s["mean_deposited_keV"] == pytest.approx(90.0)
    unknown = RangeSample(pos, [True] * 4, [False] * 4, [False] * 4, [0] * 4, [np.nan] * 4)
    assert math.isnan(summarize(unknown)["mean_deposited_keV"])


def test_stopping_table_reference_pb_in_si():
    # SRIM-2013's table for Pb-206 at 103.144 keV in Si of 2.33 g/cm3 (lunasrim reproduces it)
    ref = stopping_table_reference("Pb206", PB_MEV, SI)
    assert ref["projected_range_nm"] == pytest.approx(44.84, rel=1e-3)
    assert ref["straggling_nm"] == pytest.approx(9.44, rel=1e-3)
    assert ref["lateral_nm"] == pytest.approx(7.68, rel=1e-3)


def test_trim_semi_infinite_pb_in_si():
    sample = srim_range_sample("Pb206", PB_MEV, SI, ions=200, seed=1)
    s = summarize(sample)
    assert sample.stopped.all()
    assert s["transmitted_fraction"] == 0
    # TRIM's Monte Carlo mean range and SRIM's table agree to a few %; 200 ions give a standard
    # error of ~0.7 nm, so 10 % (4.5 nm) cannot fail by chance but catches unit or axis mix-ups.
    ref = stopping_table_reference("Pb206", PB_MEV, SI)
    assert s["projected_range_nm"] == pytest.approx(ref["projected_range_nm"], rel=0.10)
    assert s["straggling_nm"] == pytest.approx(ref["straggling_nm"], rel=0.25)
    assert s["lateral_nm"] == pytest.approx(ref["lateral_nm"], rel=0.25)
    assert np.all(sample.deposited == PB_MEV)
    assert np.all(sample.exit_energy == 0)


def test_trim_thin_layer_and_angle_convention():
    thick = summarize(srim_range_sample("Pb206", PB_MEV, SI, ions=200, seed=1))
    tilted = srim_range_sample("Pb206", PB_MEV, SI, ions=200, seed=1, angle_deg=60.0)
    t = summarize(tilted)
    # the angle is measured from the normal: at 60 degrees ions stop about half as deep and
    # drift towards +x (the plane of the tilt)
    assert 0.4 < t["projected_range_nm"] / thick["projected_range_nm"] < 0.75
    assert tilted.final_position[tilted.stopped, 0].mean() > 0.5 * t["projected_range_nm"] * 1e-6
    assert abs(tilted.final_position[tilted.stopped, 1].mean()) < 3e-6
    # 20 nm at 60 degrees: 40 nm of path against a 46 nm range, so some cross and some stop
    layer = srim_range_sample(
        "Pb206", PB_MEV, SI, ions=200, seed=1, thickness_mm=20e-6, angle_deg=60.0
    )
    s = summarize(layer)
    assert layer.transmitted.sum() + layer.stopped.sum() + layer.backscattered.sum() == 200
    assert 0.3 < s["transmitted_fraction"] < 0.9
    assert 0 < s["mean_exit_energy_keV"] < 103.144
    np.testing.assert_allclose(layer.final_position[layer.transmitted, 2], 20e-6)
    np.testing.assert_allclose(
        layer.deposited[layer.transmitted], PB_MEV - layer.exit_energy[layer.transmitted]
    )


def test_trim_backscattered_ions_on_entrance_face():
    au = Composition.from_formula("G4_Au", "Au", 19.32)
    sample = srim_range_sample("alpha", 0.01, au, ions=100, seed=3)
    assert sample.backscattered.sum() > 5  # light ion, heavy target: many come back
    np.testing.assert_allclose(sample.final_position[sample.backscattered, 2], 0.0, atol=1e-15)
    assert (sample.exit_energy[sample.backscattered] > 0).all()


def test_trim_cache_reused(monkeypatch):
    first = srim_range_sample("Pb206", PB_MEV, SI, ions=200, seed=1)
    import lunasrim

    def refuse(*args, **kwargs):
        raise AssertionError("TRIM ran although the result is cached")

    monkeypatch.setattr(lunasrim, "trim", refuse)
    again = srim_range_sample("Pb206", PB_MEV, SI, ions=200, seed=1)
    np.testing.assert_array_equal(first.final_position, again.final_position)
    with pytest.raises(AssertionError, match="cached"):
        srim_range_sample("Pb206", PB_MEV, SI, ions=200, seed=2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"energy_mev": 0.0}, "energy: must be > 0"),
        ({"energy_mev": 1e6}, "above SRIM's validity"),
        ({"ions": 0}, "ions: .* >= 1"),
        ({"angle_deg": 90.0}, "89.99 degrees"),
        ({"seed": -1}, "seed"),
        ({"thickness_mm": 0.0}, "thickness: must be > 0"),
        ({"ion": "Pu239"}, "Z = 92"),
    ],
)
def test_srim_bad_input(kwargs, match):
    args = {"ion": "Pb206", "energy_mev": PB_MEV, "ions": 10, "seed": 1} | kwargs
    with pytest.raises(ConfigError, match=match):
        srim_range_sample(composition=SI, **args)


def test_lunasrim_missing(monkeypatch):
    monkeypatch.setitem(sys.modules, "lunasrim", None)
    with pytest.raises(Score4Error, match="pip install lunasrim"):
        stopping_table_reference("Pb206", PB_MEV, SI)
