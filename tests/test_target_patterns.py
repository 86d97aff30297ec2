"""Targets of a GDML world by glob pattern, regular expression and material; a pattern that
matches nothing is one line naming the closest names."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from score4.cli.main import main
from score4.inputs.config import load_config
from score4.world.resolve import build_scene

from helpers import gdml_worlds as W


@pytest.fixture(scope="module")
def world() -> Path:
    return W.cached("pyg4", W.pyg4ometry_world)


def _scene(tmp_path: Path, world: Path, targets: list, source: str = "disk"):
    cfg = tmp_path / "run.yaml"
    data = {
        "physics": "lite",
        "world": {"gdml": str(world)},
        "targets": targets,
        "source": {"particle": "alpha", "energy": "5 MeV", "volume": source},
        "run": {"events": 10, "seed": 1},
    }
    cfg.write_text(yaml.safe_dump(data))
    return cfg, data


def test_glob_regex_and_material_select_volumes(tmp_path, world):
    cfg, _ = _scene(tmp_path, world, [{"volume": "crystal_*"}, {"material": "G4_Cu"}])
    scene = build_scene(load_config(cfg))
    assert scene.columns == ["crystal_0", "crystal_1", "crystal_2", "disk", "holder", "boolpart"]
    cfg, _ = _scene(tmp_path, world, [{"volume_regex": "crystal_[02]"}, {"volume": "disk"}])
    assert build_scene(load_config(cfg)).columns == ["crystal_0", "crystal_2", "disk"]
    cfg, _ = _scene(tmp_path, world, [{"volume": "*", "material": "G4_Cu"}])
    assert build_scene(load_config(cfg)).columns == ["disk", "holder", "boolpart"]


@pytest.mark.parametrize(
    ("target", "message"),
    [
        (
            {"volume": "cristal_*"},
            (
                r"targets\.0\.volume: no volume of .* matches 'cristal_\*'; "
                r"closest names: crystal_2, crystal_1, crystal_0;"
            ),
        ),
        (
            {"volume_regex": "dsk.*"},
            r"volume_regex: no volume .* regular expression 'dsk\.\*'; closest names: disk",
        ),
        (
            {"material": "G4_CU"},
            r"targets\.0\.material: no volume .* of material 'G4_CU'; closest materials: G4_Cu",
        ),
        ({"volume_regex": "crystal_("}, r"volume_regex: 'crystal_\(' is not a regular expression"),
        (  # too far for difflib's cutoff: the names sharing the pattern's literal start
            {"volume": "cry*X"},
            r"no volume of .* matches 'cry\*X'; closest names: crystal_0, crystal_1, crystal_2;",
        ),
        (  # nothing alike at all: still the nearest names
            {"volume_regex": "Q[0-9]+"},
            r"regular expression 'Q\[0-9\]\+'; closest names: \w+, \w+, \w+, \w+, \w+;",
        ),
        (  # the names match, the material not: what they are made of
            {"volume": "crystal_*", "material": "G4_Cu"},
            r"of material 'G4_Cu'; the volumes that match are of G4_CALCIUM_TUNGSTATE;",
        ),
    ],
)
def test_a_pattern_that_matches_nothing_is_one_line(tmp_path, world, capsys, target, message):
    cfg, _ = _scene(tmp_path, world, [target])
    assert main(["run", str(cfg), "--out", str(tmp_path / "out.h5")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1, err
    assert __import__("re").search(message, err[0]), err[0]
    assert not (tmp_path / "out.h5").exists()


def test_the_source_volume_need_not_be_scored(tmp_path, world):
    """Alphas in the copper disk, which is not a target: only the crystals are scored (the
    disk has no column) and the run counts no hit in them (the disk holds its alphas)."""
    from score4 import read_results

    cfg, _ = _scene(tmp_path, world, [{"volume": "crystal_*"}], source="disk")
    out = tmp_path / "out.h5"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    results = read_results(out)
    assert sorted(results.edep) == ["crystal_0", "crystal_1", "crystal_2"]
    assert results.n_events == 10
    assert all((e == 0).all() for e in results.edep.values())
    assert (results.primaries.position[:, 1] > 50).all()  # in the disk, at y = 60 mm


def test_a_boolean_face_area_is_reported_with_its_error(tmp_path, world):
    """The record of a source on the faces of a boolean solid (a box less a bore) states the
    area's standard error, below 0.1 % of the area, and the exact area within 4 of them."""
    import math

    from score4.source.build import source_geometry

    cfg, data = _scene(tmp_path, world, [{"volume": "crystal_0"}])
    data["source"] = {
        "particle": "alpha",
        "energy": "5 MeV",
        "surface": {"volume": "boolpart", "face": "all"},
    }
    cfg.write_text(yaml.safe_dump(data))
    config = load_config(cfg)
    record = source_geometry(config, build_scene(config))
    exact = 6 * 400 - 2 * math.pi * 25 + 2 * math.pi * 5 * 20  # 20 mm box less a 5 mm bore
    assert 0 < record["area_error_mm2"] < 1e-3 * record["area_mm2"]
    assert abs(record["area_mm2"] - exact) < 4 * record["area_error_mm2"]
