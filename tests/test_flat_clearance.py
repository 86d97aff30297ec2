"""The clearance check of a flat rough layer against a sister that is not a box is certified
(:func:`score4.world.clearance.flat_meet`): a cone tip or a ball's cap poking into the layer
between the points of its grid is refused with the sister's name and the free gap; a sister
clear of the layer by a hair is accepted."""

from __future__ import annotations

import math

import numpy as np
import pytest

import score4.world.clearance as clearance
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
LAYER_UM = 11.001  # the layer (um): 1 um base + 10 um pyramids and their margin
# (x, y) of the sister's axis over the 8 x 8 mm top face: between the points of the envelope's
# 25 x 25 grid (spaced 1/3 mm) and of the box's 9 x 9 grid (1 mm)
AT = (0.5 / 3 + 0.4, 0.5 / 3 - 1.1)


def write_world(path, solid: str, poke_um: float):
    """A silicon box (8 x 8 x 2 mm, its top at z = 1 mm) and one copper sister above it whose
    lowest point reaches ``poke_um`` into the top face's 11 um layer (< 0: that far short of
    it): ``cone`` a G4Cons standing on its tip (radius 0 at the bottom, 0.5 mm at the top,
    1 mm tall), ``ball`` a 0.2 mm orb, ``polycone`` a tip made of a G4Polycone, ``sphere`` a
    G4Sphere cap (theta 150-180 degrees, radius 0.3 mm), ``trd`` a G4Trd turned upside down
    (its narrow end 1 um wide)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 100, 100, 100, reg), "G4_Galactic", "World", reg
    )
    crystal = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("crystal_s", 8, 8, 2, reg), "G4_Si", "Crystal", reg
    )
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], crystal, "crystal", world, reg)
    bottom = 1.0 + (LAYER_UM - poke_um) * 1e-3  # the sister's lowest point
    rotation = [0, 0, 0]
    if solid == "cone":
        s = pg.geant4.solid.Cons("sister_s", 0, 0, 0, 0.5, 1.0, 0, 2 * math.pi, reg)
        z = bottom + 0.5
    elif solid == "ball":
        s = pg.geant4.solid.Orb("sister_s", 0.2, reg)
        z = bottom + 0.2
    elif solid == "polycone":
        s = pg.geant4.solid.Polycone(
            "sister_s", 0, 2 * math.pi, [0.0, 0.2, 1.0], [0, 0, 0], [0.0, 0.05, 0.4], reg
        )
        z = bottom
    elif solid == "sphere":
        s = pg.geant4.solid.Sphere(
            "sister_s", 0, 0.3, 0, 2 * math.pi, 5 * math.pi / 6, math.pi / 6, reg
        )
        z = bottom + 0.3
    else:  # trd upside down: its -z end (1 um x 1 um) at the bottom after a turn by pi about x
        s = pg.geant4.solid.Trd("sister_s", 0.4, 0.001, 0.4, 0.001, 0.5, reg)
        rotation = [math.pi, 0, 0]
        z = bottom + 0.25
    sister = pg.geant4.LogicalVolume(s, "G4_Cu", "Sister", reg)
    pg.geant4.PhysicalVolume(rotation, [AT[0], AT[1], z], sister, "sister", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml) -> dict:
    return parse_config(
        {
            "physics": "lite",
            "world": {"gdml": str(gdml)},
            "surfaces": {"p": PYRAMIDS},
            "targets": [{"volume": "crystal", "rough": [{"face": "+z", "surface": "p"}]}],
            "source": {
                "particle": "geantino",
                "energy": "1 MeV",
                "surface": {"volume": "crystal", "face": "+z"},
            },
        }
    )


def _gap_um(text: str) -> float:
    return float(text.split("free gap there: ")[1].split(" um")[0])


DEEP = pytest.mark.deep  # (each world is read by Geant4 once: ~1.7 s)


@pytest.mark.parametrize(
    "solid",
    ["cone", "trd"] + [pytest.param(s, marks=DEEP) for s in ("sphere", "ball", "polycone")],
)
def test_a_sister_poking_in_between_the_grid_points_is_refused(tmp_path, solid):
    """The sister 2 um into the layer, between the grid's points: the grid alone (the check as
    it was) lets it pass, the certified search refuses it, naming the sister and the free gap
    (the layer's thickness less 2 um, to 0.01 um)."""
    data = config(write_world(tmp_path / "w.gdml", solid, 2.0))
    with pytest.MonkeyPatch.context() as m:  # the grid of points alone
        m.setattr(clearance, "flat_meet", lambda *a, **k: None)
        (layer,) = build_scene(data).layers
    assert layer.thickness * 1e3 == pytest.approx(LAYER_UM, abs=1e-6)
    with pytest.raises(ConfigError) as err:
        build_scene(data)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith("crystal_roughpz: the rough layer on face +z of 'crystal'")
    assert "runs into sister volume 'sister'" in text
    assert _gap_um(text) == pytest.approx(LAYER_UM - 2.0, abs=0.01)


@pytest.mark.parametrize(
    ("solid", "poke_um"),
    [("cone", -0.01)]
    + [
        pytest.param(solid, poke, marks=DEEP)
        for solid in ("cone", "trd", "ball", "sphere")
        for poke in (-0.01, 0.0)
        if (solid, poke) != ("cone", -0.01)
    ],
)
def test_a_sister_clear_by_a_hair_passes(tmp_path, solid, poke_um):
    """The sister 10 nm short of the layer, and touching its top: accepted."""
    (layer,) = build_scene(config(write_world(tmp_path / "w.gdml", solid, poke_um))).layers
    assert layer.thickness * 1e3 == pytest.approx(LAYER_UM, abs=1e-6)


def write_union_world(path, poke_um: float):
    """A silicon box (8 x 8 x 2 mm) and the cone of :func:`write_world` (standing on its tip
    ``poke_um`` into the box's +z layer, at the same place) made one union solid."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 100, 100, 100, reg), "G4_Galactic", "World", reg
    )
    box = pg.geant4.solid.Box("box_s", 8, 8, 2, reg)
    cone = pg.geant4.solid.Cons("cone_s", 0, 0, 0, 0.5, 1.0, 0, 2 * math.pi, reg)
    z = 1.0 + (LAYER_UM - poke_um) * 1e-3 + 0.5
    union = pg.geant4.solid.Union("crystal_s", box, cone, [[0, 0, 0], [AT[0], AT[1], z]], reg)
    crystal = pg.geant4.LogicalVolume(union, "G4_Si", "Crystal", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], crystal, "crystal", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


@pytest.mark.parametrize("poke_um", [2.0, pytest.param(-0.01, marks=DEEP)])
def test_the_own_solids_other_part_poking_in_between_the_grid_points(tmp_path, poke_um):
    """The cone is another part of the layer's own (union) solid, 2 um into the +z face's
    layer between the grid's points: the grid alone (the check as it was) keeps every cell and
    lets the envelope run into the cone; the certified search finds it, so only the cells clear
    of the cone's column keep their patch and the envelope (their prism) stays outside it. 10
    nm short of the layer, every cell is kept."""
    from score4.inputs.config import parse_config as parse

    gdml = write_union_world(tmp_path / "u.gdml", poke_um)
    raw = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": {**PYRAMIDS, "nx": 5, "ny": 5, "width": "100 um"}},  # 0.5 mm cells
        "targets": [{"volume": "crystal", "rough": [{"face": "first.+z", "surface": "p"}]}],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "crystal", "face": "first.+z"},
        },
    }
    tip = np.array([[AT[0], AT[1], 1.0 + (LAYER_UM - max(poke_um, 0.0) / 2) * 1e-3]])
    with pytest.MonkeyPatch.context() as m:  # the grid of points alone
        m.setattr(clearance, "flat_meet", lambda *a, **k: None)
        (old,) = build_scene(parse(raw)).layers
    (layer,) = build_scene(parse(raw)).layers
    if poke_um < 0:
        assert (layer.cell_variants >= 0).all()
        assert not layer.cells_envelope
        return
    assert (old.cell_variants >= 0).all()
    assert old.in_envelope(tip).all()  # the envelope as it was runs into the cone
    assert layer.cells_envelope
    assert not layer.in_envelope(tip).any()
    assert 0 < (layer.cell_variants < 0).sum() <= 4  # the cells under the tip only
