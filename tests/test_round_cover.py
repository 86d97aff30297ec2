"""A sister that hugs a curved layer over an area without being round about its axis (a tube
segment, a box with a round hole about the layer's axis) is cleared by a round solid that
holds it (:func:`score4.world.clearance._round_cover`), searched on one half-plane: the check
passes within a small budget of cells, where the search over azimuth too runs out of it; half
a micrometre further in, the sister is refused with its name and the free gap."""

from __future__ import annotations

import math

import pytest

import score4.world.clearance as clearance
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

R = 5.0  # mm, the cylinder's radius
LAYER_UM = 11.0035  # the wall's layer (um): 1 um base + 10 um pyramids bent on the wall
PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}


def write_world(path, solid: str, rmin: float):
    """A silicon cylinder (radius 5 mm, 4 mm long) and one copper sister about its axis from
    radius ``rmin`` (mm) out, 2 mm long: ``segment`` a G4Tubs over 90 degrees of azimuth,
    ``holed`` a 14 mm box less a G4Tubs of radius ``rmin`` (a union would not do)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    cyl = pg.geant4.LogicalVolume(
        pg.geant4.solid.Tubs("cyl_s", 0, R, 4.0, 0, 2 * math.pi, reg), "G4_Si", "Cyl", reg
    )
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cyl, "cyl", world, reg)
    if solid == "segment":
        s = pg.geant4.solid.Tubs("sister_s", rmin, R + 1.0, 2.0, 0.3, math.pi / 2, reg)
    else:
        box = pg.geant4.solid.Box("box_s", 14, 14, 2.0, reg)
        hole = pg.geant4.solid.Tubs("hole_s", 0, rmin, 4.0, 0, 2 * math.pi, reg)
        s = pg.geant4.solid.Subtraction("sister_s", box, hole, [[0, 0, 0], [0, 0, 0]], reg)
    sister = pg.geant4.LogicalVolume(s, "G4_Cu", "Sister", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], sister, "sister", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml):
    return parse_config(
        {
            "physics": "lite",
            "world": {"gdml": str(gdml)},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "cyl", "rough": [{"face": "outer", "surface": "p"}]}],
            "source": {
                "particle": "geantino",
                "energy": "1 MeV",
                "surface": {"volume": "cyl", "face": "outer"},
            },
        }
    )


@pytest.mark.parametrize("solid", ["segment", pytest.param("holed", marks=pytest.mark.deep)])
def test_a_sister_hugging_the_layer(tmp_path, solid):
    """The sister from the layer's top out touches it over an area: with a budget of 20 000
    cells the check passes (the round solid holding it is searched on a half-plane); without
    that cover the search over azimuth needs more. 0.5 um further in: refused, naming the sister
    and the gap (to 0.01 um)."""
    data = config(write_world(tmp_path / "touch.gdml", solid, R + LAYER_UM * 1e-3))
    with pytest.MonkeyPatch.context() as m:
        m.setattr(clearance, "MAX_CELLS", 20_000)
        (layer,) = build_scene(data).layers
        assert layer.thickness * 1e3 == pytest.approx(LAYER_UM, abs=1e-6)  # touching
        m.setattr(clearance, "_round_clear", lambda *a: False)  # the search as it was
        with pytest.raises(ConfigError, match="needs more than 20000 cells"):
            build_scene(data)
    gap_um = LAYER_UM - 0.5
    with pytest.raises(ConfigError, match="runs into sister volume 'sister'") as err:
        build_scene(config(write_world(tmp_path / "in.gdml", solid, R + gap_um * 1e-3)))
    text = str(err.value)
    assert "\n" not in text
    assert float(text.split("free gap there: ")[1].split(" um")[0]) == pytest.approx(
        gap_um, abs=0.01
    )
