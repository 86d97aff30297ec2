"""The run record's normalisation (score4.runner.normalisation): masses, sampled areas, decays.

Volumes and areas are checked against closed formulas for square pyramids (not against the
mesh code), densities against Geant4's own NIST manager (in a spawned process), and a real run
must carry the entries in its results file.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import h5py
import pytest

from score4.cli.main import main
from score4.inputs.config import parse_config
from score4.runner.normalisation import nist_density_table, run_normalisation
from score4.world.resolve import build_scene

from conftest import ROOT, config_dict

PYRAMIDS = {"pyr": {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}}


def rough_config(**extra):
    return parse_config(
        config_dict(
            surfaces=PYRAMIDS,
            targets=[
                {
                    "name": "crystal",
                    "material": "G4_CALCIUM_TUNGSTATE",
                    "size": ["0.2 mm", "0.3 mm", "0.1 mm"],
                    "rough": [{"face": "+z", "surface": "pyr", "base_thickness": "2 um"}],
                },
                {
                    "name": "holder",
                    "material": "G4_Cu",
                    "size": ["1 mm", "1 mm", "0.5 mm"],
                    "position": ["0 mm", "0 mm", "-1 mm"],
                },
            ],
            **extra,
        )
    )


def test_rough_target_volume_and_sampled_area_match_pyramid_formulas():
    config = rough_config()
    n = run_normalisation(config, build_scene(config))
    w = h = 0.01  # mm
    cells = (0.2 / 0.1) * (0.3 / 0.1)  # 0.1 mm patches of 10 x 10 pyramids
    pyramids = cells * 100
    box = 0.2 * 0.3 * 0.1
    layer = 0.2 * 0.3 * 0.002 + pyramids * w * w * h / 3
    crystal, holder = n["volumes"]
    assert [v["name"] for v in n["volumes"]] == ["crystal", "holder"]  # events/edep order
    assert crystal["volume_mm3"] == pytest.approx(box + layer, rel=1e-12)
    assert crystal["density_g_cm3"] == pytest.approx(6.062)  # NIST CaWO4
    assert crystal["mass_kg"] == pytest.approx(6.062 * (box + layer) * 1e-6, rel=1e-12)
    assert holder["mass_kg"] == pytest.approx(8.96 * 0.5 * 1e-6, rel=1e-12)  # NIST copper
    # a square pyramid's four faces: 4 * (w / 2) * sqrt(h^2 + (w / 2)^2)
    face = 4 * (w / 2) * math.sqrt(h**2 + (w / 2) ** 2)
    src = n["source"]
    assert src["kind"] == "surface"
    assert src["area_mm2"] == pytest.approx(pyramids * face, rel=1e-12)
    assert src["projected_area_mm2"] == pytest.approx(0.2 * 0.3, rel=1e-12)
    assert n["simulated_decays"] == config.run.events
    assert n["activity_nuclide"] is None  # a plain alpha source


def test_custom_material_density_and_nuclide():
    data = config_dict(
        materials={"TeO2_x": {"formula": "TeO2", "density": "6.02 g/cm3"}},
        targets=[{"name": "bolo", "material": "TeO2_x", "size": ["5 cm", "5 cm", "5 cm"]}],
        run={"events": 1234},
    )
    data["source"] = {"decay": "Po210", "surface": {"volume": "bolo", "face": "-x"}}
    config = parse_config(data)
    n = run_normalisation(config, build_scene(config))
    assert n["volumes"][0]["mass_kg"] == pytest.approx(0.7525, rel=1e-12)  # 125 cm3 * 6.02 g/cm3
    assert n["source"]["area_mm2"] == n["source"]["projected_area_mm2"] == pytest.approx(2500)
    assert n["activity_nuclide"] == "Po210"
    assert n["simulated_decays"] == 1234


def test_shipped_nist_densities_equal_the_installed_geant4():
    code = (
        "import json, sys; sys.path.insert(0, 'tools'); from nist_densities import nist_densities;"
        "print(json.dumps(nist_densities()))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True
    )
    version, live = json.loads(out.stdout.strip().splitlines()[-1])
    shipped = nist_density_table()
    assert len(shipped) > 300
    assert shipped == pytest.approx(live, rel=1e-9), (
        f"Geant4 {version} differs from src/score4/data/nist_densities.json: run "
        "tools/nist_densities.py"
    )


def test_run_record_holds_the_normalisation(tmp_path):
    cfg = tmp_path / "run.yaml"
    data = config_dict(run={"events": 20, "seed": 3})
    import yaml

    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "r.h5"
    assert main(["-q", "run", str(cfg), "--out", str(out)]) == 0
    with h5py.File(out, "r") as f:
        run = {k: f["run"].attrs[k] for k in f["run"].attrs}
    volumes = json.loads(run["volumes"])
    assert volumes[0]["name"] == "crystal"
    assert volumes[0]["mass_kg"] == pytest.approx(2.33e-3)
    assert json.loads(run["source"])["area_mm2"] == pytest.approx(100.0)
    assert int(run["simulated_decays"]) == 20
    assert run["activity_nuclide"] == "null"  # JSON null: no nuclide for a particle source


def test_vertex_file_drawn_by_score4_keeps_its_sampled_area(tmp_path):
    cfg = tmp_path / "rough.yaml"
    data = config_dict(
        surfaces=PYRAMIDS,
        targets=[
            {
                "name": "crystal",
                "size": ["0.2 mm", "0.2 mm", "0.1 mm"],
                "rough": [{"face": "+z", "surface": "pyr"}],
            }
        ],
        run={"events": 50},
    )
    data["source"] = {"decay": "Po210", "surface": {"volume": "crystal", "face": "+z"}}
    import yaml

    cfg.write_text(yaml.safe_dump(data))
    vertices = tmp_path / "v.h5"
    assert main(["vertices", str(cfg), "--out", str(vertices)]) == 0
    drawn = parse_config(data, base_dir=tmp_path)
    replay = parse_config(
        {
            "targets": data["targets"],
            "surfaces": PYRAMIDS,
            "source": {"vertices": str(vertices)},
            "run": {"events": 50},
        }
    )
    src = run_normalisation(replay, build_scene(replay))["source"]
    direct = run_normalisation(drawn, build_scene(drawn))["source"]
    assert src["kind"] == "vertices"
    assert src["drawn_from"] == "surface"
    assert src["area_mm2"] == pytest.approx(direct["area_mm2"], rel=1e-12)
    assert run_normalisation(replay, build_scene(replay))["activity_nuclide"] == "Po210"
