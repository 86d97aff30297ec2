"""``score4 range``: validation, SRIM side, printing and plots.

With a stand-in for score4's transport.

score4's own ion transport (``score4.sim.range_run.simulate_range``) is replaced here by a fake
that returns a fixed Gaussian depth distribution, so these tests check the command itself; the
transport is tested with the transport. TRIM runs are small (200 ions) and cached per session.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from score4.cli.main import main
from score4.ions.composition import Composition
from score4.ions.srim_reference import RangeSample

NIST = ["G4_Si", "G4_Ge", "G4_Cu", "G4_CALCIUM_TUNGSTATE", "G4_SODIUM_IODIDE", "G4_Galactic"]


@pytest.fixture(scope="module", autouse=True)
def _srim_cache(tmp_path_factory):
    """The session's TRIM cache (shared with test_srim_reference), outside the user's cache."""
    old = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(tmp_path_factory.getbasetemp() / "xdg-cache")
    yield
    if old is None:
        os.environ.pop("XDG_CACHE_HOME", None)
    else:
        os.environ["XDG_CACHE_HOME"] = old


@pytest.fixture
def fake(monkeypatch):
    """Install a fake score4.sim.range_run; return the list of its calls."""
    calls = []

    def simulate_range(
        ion,
        energy_mev,
        material,
        events,
        seed,
        thickness_mm=None,
        angle_deg=0.0,
        materials=None,
        alphas="geant4",
    ):
        calls.append(dict(locals()))
        os.write(1, b"Geant4 chatter on the C++ side\n")  # must not reach stdout (--json)
        rng = np.random.default_rng(seed)
        pos = np.column_stack(
            [
                rng.normal(0, 8e-6, events),
                rng.normal(0, 8e-6, events),
                rng.normal(46e-6, 10e-6, events),
            ]
        )
        trans = np.zeros(events, bool) if thickness_mm is None else pos[:, 2] > thickness_mm
        pos[trans, 2] = thickness_mm if thickness_mm is not None else 0
        exit_e = np.where(trans, 0.03, 0.0)
        if materials and material in materials:
            comp = materials[material].composition(material)
        else:
            comp = Composition.from_formula(material, "Si", 2.33)
        sample = RangeSample(
            pos, ~trans, np.zeros(events, bool), trans, exit_e, energy_mev - exit_e
        )
        return sample, comp

    module = types.ModuleType("score4.sim.range_run")
    module.simulate_range = simulate_range
    monkeypatch.setitem(sys.modules, "score4.sim.range_run", module)
    monkeypatch.setattr("score4.cli.range_cmd.nist_names", lambda: list(NIST))
    return calls


def _run(capfd, *args) -> tuple[int, str, str]:
    status = main(["range", *args])
    out, err = capfd.readouterr()
    return status, out, err


def test_table_with_srim(fake, capfd):
    status, out, err = _run(
        capfd, "Pb206", "103.144 keV", "G4_Si", "--events", "200", "--compare-srim"
    )
    assert status == 0, err
    assert "Pb-206 103.144 keV into G4_Si (Si, 2.33 g/cm3), semi-infinite block" in out
    for label in (
        "projected range",
        "longitudinal straggling",
        "lateral straggling",
        "backscattered fraction",
        "transmitted fraction",
        "mean deposited energy",
        "SRIM range table",
        "ratio",
    ):
        assert label in out
    assert "Geant4 chatter" not in out
    assert "TRIM (lunasrim): 200 ions" in err
    assert "TRIM 200/200 ions" in err
    (call,) = fake
    assert call["ion"] == "Pb206"
    assert call["energy_mev"] == pytest.approx(0.103144)
    assert call["material"] == "G4_Si"
    assert call["thickness_mm"] is None
    assert call["seed"] == 1


def test_json_keys_and_srim_values(fake, capfd):
    status, out, err = _run(
        capfd, "Pb-206", "103.144 keV", "G4_Si", "-n", "200", "--compare-srim", "--json", "-q"
    )
    assert status == 0, err
    assert err == ""  # --quiet
    data = json.loads(out)  # nothing but JSON on stdout, NaN written as null
    keys = ["projected_range_nm", "straggling_nm", "lateral_nm", "backscattered_fraction"]
    for key in [*keys, "transmitted_fraction", "mean_deposited_keV"]:
        assert key in data
        assert key in data["srim"]
    assert data["projected_range_nm"] == pytest.approx(46, abs=2.5)  # the fake's 46 nm
    # TRIM with its own seed (never the libraries'): 200 ions, 45.9 nm (1000 ions, seed 1, in
    # docs/data/srim_reference.csv) within 3 standard errors (straggling 10.2 nm / sqrt(200))
    from score4.runner.seeds import reference_trim_seed

    assert data["seed"] == 1
    assert data["srim"]["trim_seed"] == reference_trim_seed(1)
    assert data["srim"]["projected_range_nm"] == pytest.approx(45.9, abs=2.2)
    assert data["srim"]["table"]["projected_range_nm"] == pytest.approx(44.84, rel=1e-3)
    assert data["srim"]["events"] == 200
    assert data["mean_exit_energy_keV"] is None
    assert data["density_g_cm3"] == 2.33
    assert data["composition"] == {"Si": 1.0}


def test_thin_layer_png_and_formula_with_density(fake, capfd, tmp_path):
    png = tmp_path / "depth.png"
    status, out, err = _run(
        capfd,
        "Pb206",
        "103 keV",
        "TeO2",
        "--density",
        "6.02 g/cm3",
        "--thickness",
        "40 nm",
        "--angle",
        "60",
        "-n",
        "200",
        "--compare-srim",
        "--srim-events",
        "100",
        "--png",
        str(png),
    )
    assert status == 0, err
    assert "layer of 40 nm, 60 deg from the normal" in out
    assert "(TeO2, 6.02 g/cm3)" in out
    assert png.stat().st_size > 10_000
    assert f"wrote {png}" in err
    (call,) = fake
    assert call["thickness_mm"] == pytest.approx(40e-6)
    assert call["angle_deg"] == 60.0
    assert call["materials"]["TeO2"].density == 6.02
    rows = {line[:34].strip(): line for line in out.splitlines()}
    assert "0." in rows["transmitted fraction"]
    assert "keV" in rows["mean exit energy (transmitted)"]


def test_materials_from_config(fake, capfd, tmp_path):
    config = tmp_path / "m.yaml"
    config.write_text("materials:\n  Li2MoO4: {formula: Li2MoO4, density: 3.07 g/cm3}\n")
    status, out, err = _run(
        capfd, "alpha", "5.3 MeV", "Li2MoO4", "--config", str(config), "-n", "50"
    )
    assert status == 0, err
    assert "alpha 5300 keV into Li2MoO4 (Li2MoO4, 3.07 g/cm3)" in out
    assert "SRIM" not in out
    assert fake[0]["ion"] == "alpha"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["Xx206", "103 keV", "G4_Si"], "ION: unknown ion 'Xx206'"),
        (["alpah", "5 MeV", "G4_Si"], "closest: alpha"),
        (
            ["Pb206", "103 keV", "G4_Silicon"],
            "MATERIAL: unknown material 'G4_Silicon'; closest: .*G4_Si",
        ),
        (["Pb206", "103 keV", "sodium_iodide"], "closest: G4_SODIUM_IODIDE"),
        (["Pb206", "0 keV", "G4_Si"], "ENERGY: must be greater than 0"),
        (["Pb206", "-5 keV", "G4_Si"], "ENERGY: must be greater than 0"),
        (["Pb206", "103", "G4_Si"], "ENERGY: '103' has no unit"),
        (
            ["alpha", "10 GeV", "G4_Si", "--compare-srim"],
            r"above SRIM's validity for alpha \(2 GeV/amu = 8005.21 MeV\)",
        ),
        (["Pb206", "103 keV", "G4_Si", "--events", "0"], "--events: must be >= 1"),
        (["Pb206", "103 keV", "G4_Si", "--events", "many"], "--events: expected an integer"),
        (["Pb206", "103 keV", "G4_Si", "--angle", "90"], "--angle: .* <= 89.99 degrees"),
        (["Pb206", "103 keV", "G4_Si", "--angle", "-10"], "--angle: .* >= 0"),
        (
            ["Pb206", "2 MeV", "G4_Si"],
            r"above the validity of score4's heavy-ion model for Pb-206: .* up to 1 MeV",
        ),
        (
            ["Pb206", "103 keV", "G4_Si", "--thickness", "0 nm"],
            "--thickness: must be greater than 0",
        ),
        (["Pb206", "103 keV", "G4_Si", "--thickness", "20"], "--thickness: '20' has no unit"),
        (
            ["Pb206", "103 keV", "G4_Si", "--density", "2 g/cm3"],
            "--density: 'G4_Si' is a named material",
        ),
        (["Pb206", "103 keV", "TeO2", "--density", "6"], "--density: .*has no unit"),
        (["Pb206", "103 keV", "teo2", "--density", "6 g/cm3"], "not a chemical formula"),
        (
            ["Pu239", "1 MeV", "G4_Si", "--compare-srim"],
            "Z = 94; SRIM/TRIM knows ions up to Z = 92",
        ),
        (
            ["Pb206", "103 keV", "G4_Si", "--config", "missing.yaml"],
            "--config: file 'missing.yaml' does not exist",
        ),
    ],
)
def test_bad_input_one_line_exit_2(fake, capfd, args, message):
    import re

    status, out, err = _run(capfd, *args)
    assert status == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("score4: error: ")
    assert re.search(message, err), err
    assert fake == []  # refused before any simulation


def test_bad_materials_in_config(fake, capfd, tmp_path):
    config = tmp_path / "m.yaml"
    config.write_text("materials:\n  TeO2: {formula: TeO2, density: 6.02}\n")
    status, _, err = _run(capfd, "Pb206", "103 keV", "TeO2", "--config", str(config))
    assert status == 2
    assert "materials.TeO2.density: 6.02 has no unit" in err


def test_lunasrim_missing(fake, capfd, monkeypatch):
    monkeypatch.setitem(sys.modules, "lunasrim", None)
    status, _, err = _run(capfd, "Pb206", "103 keV", "G4_Si", "--compare-srim")
    assert status == 2
    assert err.strip().endswith("pip install lunasrim")
    assert len(err.strip().splitlines()) == 1
    assert fake == []


def test_transport_module_missing(capfd, monkeypatch):
    monkeypatch.setitem(sys.modules, "score4.sim.range_run", None)
    monkeypatch.setattr("score4.cli.range_cmd.nist_names", lambda: list(NIST))
    status, _, err = _run(capfd, "Pb206", "103 keV", "G4_Si")
    assert status == 2
    assert "score4.sim.range_run" in err


def test_unknown_material_with_real_geant4_names(tmp_path):
    # Geant4's own NIST list (in a fresh process: pytest itself never imports Geant4)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    proc = subprocess.run(
        [sys.executable, "-m", "score4.cli.main", "range", "Pb206", "103 keV", "CaWO4"],
        check=False,
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert "MATERIAL: unknown material 'CaWO4'" in proc.stderr
    assert "chemical formula with --density" in proc.stderr


def test_depth_plot_shares_bins_and_normalises(tmp_path):
    from score4.analysis.plots import plot_range_depths

    rng = np.random.default_rng(4)

    def sample(mean_nm, n):
        pos = np.column_stack([np.zeros(n), np.zeros(n), rng.normal(mean_nm, 5, n) * 1e-6])
        none = np.zeros(n, bool)
        return RangeSample(pos, ~none, none, none, np.zeros(n), np.full(n, 0.1))

    drawn = plot_range_depths(
        {"score4": sample(40, 300), "TRIM": sample(45, 500)}, tmp_path / "d.png", "test"
    )
    widths = np.diff(drawn.edges_nm)
    assert [float((d * widths).sum()) for d in drawn.density] == pytest.approx([1.0, 1.0])
    assert drawn.stopped == [300, 500]
    assert drawn.edges_nm[0] >= 0
    assert (tmp_path / "d.png").stat().st_size > 10_000
