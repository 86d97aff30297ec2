"""Steps and activeness on a boolean face with ``into: true`` (score4.world.boolean_distance):
the face is measured by its rough surface on the cut face (the patch tops of the kept cells and
the cut face elsewhere), the other faces as on a plain solid with ``into`` (the uncut solid's),
a smooth face as it is on the boolean; in a small Geant4 run on a copper box less a tube,
against a brute force over the patch tops of the cells around each step (no k-d tree, no
search bound)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from score4.world.activeness import weight
from score4.world.resolve import build_scene

from helpers.into_steps import brute_rough, into_steps_run

HALF, BORE = 10.0, 5.0  # the box's half width and the bore's radius, mm


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """A 20 mm copper box less a tube (r 5 mm, 40 mm long) along z, at the origin."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 100, 100, 100, reg), "G4_Galactic", "W", reg)
    box = s.Box("cut_a", 2 * HALF, 2 * HALF, 2 * HALF, reg)
    hole = s.Tubs("cut_b", 0, BORE, 40, 0, 2 * np.pi, reg)
    cut = s.Subtraction("cutbox_s", box, hole, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "cutbox_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "cutbox", world, reg)
    reg.setWorld(world.name)
    path = tmp_path_factory.mktemp("into_distance") / "cutbox.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def test_steps_and_activeness_with_into_on_a_boolean_face(gdml, tmp_path):
    """Alphas from the pyramids cut into the box's +z face (into: true), steps and a 3 um
    transition layer under that face, 30 events, seed 11: each step's dist_to_surf is the
    nearest of the brute-force rough surface (its flat cells at the cut face, z = 10 mm less the
    layer's thickness), the box's other faces and the bore, to 1e-9 mm; steps in the slab the
    layer was cut from are all in patches; active_edep weights each step by the brute-force
    distance to the rough face and (a 2 mm transition layer) by the distance to the bore's
    wall, kept between the box's faces (1e-9 MeV)."""
    cfg, res, evtid, edep, world, dist = into_steps_run(
        gdml, "cutbox", "first.+z", ("second.outer", "2 mm"), 11, tmp_path
    )
    scene = build_scene(cfg)
    layer = scene.layer("cutbox", "first.+z")
    t = layer.thickness
    p = scene.target("cutbox").to_local(world)
    assert layer.frame.to_local(scene.target("cutbox").to_world(np.zeros((1, 3))))[0, 2] == (
        pytest.approx(-(HALF - t), abs=1e-12)
    )  # the layer's flat level: the cut face
    in_patch = layer.contains(world)
    slab = p[:, 2] > HALF - t
    assert slab.sum() > 20
    assert in_patch[slab].all()
    rough = brute_rough(layer, world)
    assert rough.max() < min(layer.patch_size)  # the 3 x 3 cells hold every nearest point
    others = np.min(
        [HALF - p[:, 0], HALF + p[:, 0], HALF - p[:, 1], HALF + p[:, 1], HALF + p[:, 2]], axis=0
    )
    others = np.minimum(others, np.hypot(p[:, 0], p[:, 1]) - BORE)
    np.testing.assert_allclose(dist, np.minimum(rough, others), rtol=0, atol=1e-9)
    under = ~in_patch & (others > rough)
    assert under.sum() > 10  # in the copper under the cut face: 1 um (the base) below it at least
    assert np.all(rough[under] >= HALF - t - p[under, 2] + 1e-3 - 1e-9)
    # the bore's wall as it is on the (uncut) box: r = 5 mm for |z| <= 10 mm
    r = np.hypot(p[:, 0], p[:, 1])
    bore = np.hypot(r - BORE, np.maximum(np.abs(p[:, 2]) - HALF, 0.0))
    assert (bore < 2.0).sum() > 5  # steps the bore's entry weights
    w = np.minimum(weight(rough, 3e-3, 0.5), weight(bore, 2.0, 0.2))
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["cutbox"], atol=1e-9, rtol=0)
    assert 0 < again.sum() < res.edep["cutbox"].sum()
