"""The one reader of GDML includes (``score4.files.gdml_include_refs``) and its three users: the
output check's walk (``files.gdml_includes``), the world's file list (``gdml_files``) and the
export's relinking (``gdml_splice.relink``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from score4.errors import ConfigError
from score4.files import gdml_include_refs, gdml_includes
from score4.geometry.gdml_splice import relink
from score4.world.gdml_files import gdml_files

MAIN = """<?xml version="1.0"?>
<!DOCTYPE gdml [
<!ENTITY materials SYSTEM "materials.xml">
]>
<gdml>
&materials;
<structure>
  <file name="parts/crystal.gdml" volname="crystal"/>
  <file volname='holder' name='parts/holder.gdml'/>
</structure>
</gdml>
"""


@pytest.fixture
def world(tmp_path: Path) -> Path:
    (tmp_path / "parts").mkdir()
    (tmp_path / "materials.xml").write_text("<materials/>\n")
    (tmp_path / "parts" / "crystal.gdml").write_text("<gdml/>\n")
    (tmp_path / "parts" / "holder.gdml").write_text('<gdml><file name="screw.gdml"/></gdml>\n')
    (tmp_path / "parts" / "screw.gdml").write_text("<gdml/>\n")
    main = tmp_path / "world.gdml"
    main.write_text(MAIN)
    return main


def test_refs_name_each_include_once_and_not_volname():
    refs = gdml_include_refs(MAIN)
    assert [(kind, name) for kind, name, _ in refs] == [
        ("entity", "materials.xml"),
        ("file", "parts/crystal.gdml"),
        ("file", "parts/holder.gdml"),
    ]
    assert all(MAIN[a:b] == name for _, name, (a, b) in refs)


def test_the_three_walkers_see_the_same_files(world: Path):
    folder = world.parent
    expected = {
        folder / "materials.xml",
        folder / "parts" / "crystal.gdml",
        folder / "parts" / "holder.gdml",
        folder / "parts" / "screw.gdml",
    }
    assert {p.resolve() for p in gdml_includes(world)} == expected
    assert set(gdml_files(world)) == expected | {world}


def test_a_missing_file_include_is_one_line(world: Path):
    (world.parent / "parts" / "screw.gdml").unlink()
    with pytest.raises(ConfigError, match=r"<file name='screw.gdml'> not found"):
        gdml_files(world)


def test_relink_moves_every_include_and_nothing_else(world: Path):
    out = relink(MAIN, world.parent, world.parent / "export")
    assert '<!ENTITY materials SYSTEM "../materials.xml">' in out
    assert '<file name="../parts/crystal.gdml" volname="crystal"/>' in out
    assert "<file volname='holder' name='../parts/holder.gdml'/>" in out
    assert out.replace("../", "") == MAIN
    assert relink(MAIN, world.parent, world.parent) == MAIN
