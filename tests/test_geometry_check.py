"""Geant4 overlap check of generated geometries (placements in the world and patch placements)."""

from __future__ import annotations

import yaml

from score4.cli.main import main

from conftest import config_dict
from helpers.spawn import run_in_spawned_process

ROUGH = config_dict(
    surfaces={
        "p": {
            "kind": "spikes",
            "nx": 10,
            "ny": 10,
            "width": "10 um",
            "height": "10 um",
            "height_sigma": "2 um",
        }
    },
    targets=[
        {
            "name": "crystal",
            "material": "G4_Si",
            "size": ["3 mm", "0.3 mm", "0.2 mm"],
            "position": ["0 mm", "0 mm", "-0.1 mm"],
            "rough": [
                {"face": "+z", "surface": "p"},
                {"face": "-x", "surface": "p", "solid": "tessellated"},
            ],
        }
    ],
)


def _check(data: dict, plant: bool):
    from helpers import g4_geometry_check

    return run_in_spawned_process(g4_geometry_check.check, data, plant)


def test_generated_rough_layers_do_not_overlap_and_a_planted_overlap_is_found():
    ok, overlaps, checked, exact, total = _check(ROUGH, False)
    # 1 crystal + 2 envelopes; +z: 30 x 3 cells (> 20: not by Geant4); -x: 3 x 2 cells by Geant4;
    # all patches exactly
    assert ok
    assert overlaps == []
    assert total == 3 + 90 + 6
    assert checked == 3 + 6
    assert exact == 90 + 6
    ok, overlaps, *_ = _check(ROUGH, True)
    assert not ok
    assert any(o.startswith("intruder") for o in overlaps)


def test_nested_layout_is_checked_group_by_group_and_cell_by_cell():
    """+z in nested groups (30 x 3 cells: 4 groups of 8 x 3, the last 6 x 3): Geant4 checks the
    4 groups, the exact check all 90 cells."""
    import copy

    nested = copy.deepcopy(ROUGH)
    nested["targets"][0]["rough"][0]["native_layout"] = "nested"
    ok, overlaps, checked, exact, total = _check(nested, False)
    assert ok
    assert overlaps == []
    assert total == 3 + 90 + 6
    assert checked == 3 + 4 + 6
    assert exact == 90 + 6


def test_exact_cell_check_finds_a_patch_wider_than_its_cell():
    from score4.geometry.check import patches_fit_their_cells
    from score4.inputs.config import parse_config
    from score4.world.resolve import build_scene

    layer = build_scene(parse_config(ROUGH)).layers[0]
    assert patches_fit_their_cells(layer) == []
    layer.patch_map = type(layer.patch_map)(
        layer.patch_map.variants, (0.09, 0.1), (1.0,)
    )  # cells narrower than the patch
    assert patches_fit_their_cells(layer) == [
        f"{layer.name}: variant 'p' reaches outside its 90 x 100 um cell"
    ]


def test_cli_geometry_check_twice_in_one_process(tmp_path, capsys):
    """Two checks of different worlds in one process (a program calling main() twice): each
    builds its world in a process of its own. Built in the calling process, the second check's
    GDML world took the first world's volumes from Geant4's stores by name, and Geant4 reported
    the bore's layer overlapping the first world's crystal (exit status 1)."""
    from test_curved_rough import cylinder_config, write_cylinder

    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump(ROUGH))
    gdml = write_cylinder(tmp_path / "bore.gdml", radius=1.0, half_z=0.4, rmin=0.6)
    bore = tmp_path / "bore.yaml"
    bore.write_text(yaml.safe_dump(cylinder_config(gdml, face="inner")))
    for path, placements in ((cfg, "3 of 99"), (bore, "56 of 157")):
        assert (
            main(["geometry", "check", str(path), "--points", "200", "--max-placements", "5"]) == 0
        )
        out = capsys.readouterr().out
        assert f"Geant4 checked {placements} placements" in out
        assert "no overlaps" in out
