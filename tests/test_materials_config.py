"""``materials:`` in the run configuration: validation, compositions, a real Geant4 run in TeO2."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results

from conftest import config_dict
from helpers.spawn import run_in_spawned_process

MATERIALS = {
    "TeO2": {"formula": "TeO2", "density": "6.02 g/cm3"},
    "Li2MoO4": {"formula": "Li2MoO4", "density": "3070 kg/m3"},
    "my_alloy": {"elements": {"Cu": 0.99, "Sn": 0.01}, "fractions": "mass", "density": "8.9 g/cm3"},
}


def _config(materials=MATERIALS, material="TeO2", **sections):
    target = {"name": "crystal", "material": material, "size": ["1 mm"] * 3}
    return parse_config(config_dict(materials=materials, targets=[target], **sections))


def test_materials_parse_and_compose():
    config = _config()
    te = config.materials["TeO2"]
    assert te.density == pytest.approx(6.02)
    assert config.materials["Li2MoO4"].density == pytest.approx(3.07)
    comp = te.composition("TeO2")
    assert dict(comp.atoms) == pytest.approx({"Te": 1 / 3, "O": 2 / 3})
    # 1 % tin by mass in copper: atoms Sn/Cu = (0.01/118.69) / (0.99/63.546)
    alloy = dict(config.materials["my_alloy"].composition("my_alloy").atoms)
    assert alloy["Sn"] / alloy["Cu"] == pytest.approx((0.01 / 118.69) / (0.99 / 63.546), rel=1e-3)
    # stored with units, so a stored config validates again to the same materials
    again = parse_config(config.model_dump(mode="json"))
    assert again.materials == config.materials


@pytest.mark.parametrize(
    ("materials", "match"),
    [
        (
            {"X": {"formula": "TeXx2", "density": "6 g/cm3"}},
            r"materials.X: unknown element symbol 'Xx'",
        ),
        (
            {"X": {"elements": {"Cu": 1, "Sm9": 1}, "density": "6 g/cm3"}},
            "unknown element symbol 'Sm9'",
        ),
        ({"X": {"formula": "TeO2", "density": 6.02}}, r"materials.X.density: .*has no unit"),
        ({"X": {"formula": "TeO2", "density": "6.02 g"}}, r"unknown density unit 'g'"),
        ({"X": {"formula": "TeO2"}}, r"materials.X.density: Field required"),
        ({"G4_TeO2": {"formula": "TeO2", "density": "6 g/cm3"}}, "G4_ belong to Geant4's NIST"),
        ({"X": {"formula": "TeO2", "elements": {"Te": 1}, "density": "6 g/cm3"}}, "not both"),
        (
            {"X": {"formula": "TeO2", "fractions": "mass", "density": "6 g/cm3"}},
            r"fractions: used only with elements given \(here elements is not given\)",
        ),
        (
            {"X": {"elements": {"Cu": 0}, "density": "6 g/cm3"}},
            "fractions must be finite numbers > 0",
        ),
        ({"X": {"formula": "teo2", "density": "6 g/cm3"}}, "not a chemical formula"),
    ],
)
def test_materials_bad_input(materials, match):
    with pytest.raises(ConfigError, match=match):
        _config(materials=materials, material="G4_Si")


def _geant4_materials(materials: dict, names: list[str]) -> dict:
    """In a fresh process: build the materials in Geant4, return their compositions."""
    from score4.inputs.material_spec import MaterialSpec
    from score4.inputs.materials import find_material
    from score4.ions.composition import Composition
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    specs = {k: MaterialSpec.model_validate(v) for k, v in materials.items()}
    out = {}
    for name in names:
        try:
            m = find_material(g4, name, "material", specs)
        except ConfigError as err:
            out[name] = str(err)
            continue
        c = Composition.from_g4_material(m)
        out[name] = {"atoms": dict(c.atoms), "density": c.density, "name": str(m.GetName())}
    return out


def _in_process(fn, *args):
    return run_in_spawned_process(fn, *args)


def test_geant4_builds_the_materials():
    sys.path.insert(0, str(Path(__file__).parent))
    out = _in_process(_geant4_materials, MATERIALS, ["TeO2", "my_alloy", "TeO2", "Te02", "G4_Si"])
    te = out["TeO2"]
    assert te["name"] == "TeO2"
    assert te["density"] == pytest.approx(6.02)
    assert te["atoms"] == pytest.approx({"Te": 1 / 3, "O": 2 / 3}, rel=1e-9)
    alloy = out["my_alloy"]["atoms"]
    # Geant4's atomic masses: Sn 118.71, Cu 63.546 g/mole
    assert alloy["Sn"] / alloy["Cu"] == pytest.approx((0.01 / 118.71) / (0.99 / 63.546), rel=1e-3)
    assert "unknown material 'Te02'; closest names: TeO2" in out["Te02"]
    assert out["G4_Si"]["atoms"] == {"Si": 1.0}


def test_geant4_run_in_a_teo2_target(tmp_path: Path):
    # 5.3 MeV alphas along the inward normal into TeO2 (6.02 g/cm3): each stops and deposits its
    # energy; the summed track length is SRIM's projected range within 6 % (Geant4's ASTAR
    # stopping and SRIM's differ by a few %, and the path is slightly longer than the depth;
    # measured: 1.029).
    # A wrong density or composition (e.g. Te only, or 5.02 g/cm3) moves it by > 15 %.
    import lunasrim

    config = _config(
        source={"direction": "normal", "surface": {"volume": "crystal", "face": "+z"}},
        output={"track_length": True},
        run={"events": 40, "seed": 5},
    )
    res = read_results(run(config, tmp_path / "teo2.h5", progress=False, echo=lambda m: None))
    edep, length = res.edep["crystal"], res.scores["track_length"]["crystal"]
    assert res.n_events == 40
    np.testing.assert_allclose(edep, 5.3, atol=0.02)  # delta electrons may leave near the face
    (row,) = lunasrim.stopping_table("He", {"Te": 1, "O": 2}, emin=5300, emax=5300, density=6.02)
    srim_range_mm = row[3] * 1e-7
    assert np.median(length) == pytest.approx(srim_range_mm, rel=0.06)
