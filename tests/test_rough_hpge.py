"""A LEGEND BEGe written with its metadata (examples/bege/write_bege.py --metadata): the surface
groups reach the run's targets, and rough face lists make one layer per face."""

from __future__ import annotations

import runpy
import shutil
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import load_config
from score4.world.resolve import build_scene

pytest.importorskip("pygeomhpges")
pytest.importorskip("pygeomtools")

EXAMPLE = Path(__file__).parent.parent / "examples" / "rough_hpge"


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rough_hpge")
    writer = runpy.run_path(str(EXAMPLE.parent / "bege" / "write_bege.py"), run_name="write")
    writer["main"](str(out / "bege.gdml"), metadata=True)
    for f in ("po210_flat.yaml", "po210_rough.yaml"):
        shutil.copy(EXAMPLE / f, out / f)
    return out


def test_metadata_groups_reach_the_target(folder):
    scene = build_scene(load_config(folder / "po210_flat.yaml"))
    shape = scene.target("bege").shape
    assert shape is not None
    assert shape.groups["pplus"] == ("seg_0a",)
    assert shape.groups["passive"] == ("seg_0b", "seg_1", "seg_2", "seg_3")
    assert shape.face_area("pplus") == pytest.approx(np.pi * 7.5**2, rel=1e-12)
    assert scene.model is not None
    assert scene.model.metadata["bege"]["type"] == "bege"


def test_rough_face_list_makes_one_layer_per_face(folder):
    scene = build_scene(load_config(folder / "po210_rough.yaml"))
    assert [layer.config.face for layer in scene.layers] == ["seg_0a", "seg_1", "seg_2", "seg_3"]
    assert [type(layer).__name__ for layer in scene.layers] == [
        "RingRoughLayer",
        "CurvedRoughLayer",
        "RingRoughLayer",
        "CurvedRoughLayer",
    ]
    assert {layer.config.surface for layer in scene.layers} == {"pyramids"}


def test_face_given_twice_through_a_group_is_refused(folder):
    text = (folder / "po210_rough.yaml").read_text()
    bad = folder / "twice.yaml"
    bad.write_text(
        text.replace(
            "- {face: [pplus, seg_1, seg_2, seg_3], surface: pyramids}",
            "- {face: [pplus, seg_1], surface: pyramids}\n      - {face: seg_0, surface: pyramids}",
        )
    )
    with pytest.raises(ConfigError, match=r"targets\.0\.rough\.1: face seg_0a of 'bege' is rough"):
        build_scene(load_config(bad))


def test_listing_shows_the_metadata_surfaces(folder):
    from score4.world.listing import geometry_rows, geometry_text

    rows = geometry_rows(build_scene(load_config(folder / "po210_rough.yaml")))
    (target,) = rows["targets"]
    assert target["groups"]["pplus"] == ["seg_0a"]
    assert "seg_0a" in target["faces"]
    assert "seg_0" not in target["faces"]
    text = geometry_text(rows)
    assert "    surfaces (metadata): pplus seg_0a; passive seg_0b, seg_1, seg_2, seg_3; " in text
