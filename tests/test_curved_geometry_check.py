"""The overlap check of curved layers (``score4 geometry check``): an exact numpy check that the
cells tile the envelope (neighbouring rings share their bounding cones, neighbouring cells their
azimuths, every patch body in its cell) and Geant4's own check on sampled neighbourhoods."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest
from test_bege_whole_surface import MINI, WRITER, config

from score4.geometry.check import curved_cells_tile
from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

from helpers.spawn import run_in_spawned_process

pytest.importorskip("pygeomhpges")


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("bege_check") / "mini.gdml"
    runpy.run_path(str(WRITER), run_name="write")["main"](str(out), metadata=True, detector=MINI)
    return out


def layer_of(gdml: Path, face: str):
    (layer,) = build_scene(parse_config(config(gdml, face=face, source_face=face))).layers
    return layer


@pytest.mark.parametrize("face", ["seg_1", "seg_6", "seg_7"])  # groove wall, side, taper
def test_the_cells_of_a_curved_layer_tile_its_envelope(gdml, face):
    layer = layer_of(gdml, face)
    n, problems = curved_cells_tile(layer)
    assert n == layer.ring_layout.n_cells
    assert problems == []


def test_a_ring_moved_into_its_neighbour_is_caught(gdml):
    """Ring 1 of the taper moved 10 um along the generator into ring 0: an overlap of 10 um
    between them (at the face and at the layer's top), and a gap on its other side."""
    layer = layer_of(gdml, "seg_7")
    lay = layer.ring_layout
    assert len(lay.v) >= 2
    lay.v[1] -= 0.01 * (1 if lay.v[1] > lay.v[0] else -1)
    _, problems = curved_cells_tile(layer)
    assert f"{layer.name}: rings 0 and 1 leave an overlap of 10 um between them at the face" in (
        problems
    )


def test_a_patch_below_the_face_and_overlapping_cells_are_caught(gdml):
    """A layer whose patches sink 0.1 um into the crystal (lift made negative) and a ring whose
    cells are turned 1 % closer together than its patches are wide (each patch reaches into its
    neighbour's cell: 1 % of 500 um at the cell's edges, halved, on either side)."""
    layer = layer_of(gdml, "seg_7")
    layer.lift = -1e-4
    _, problems = curved_cells_tile(layer)
    assert any("reaches" in p and "outside its cell" in p for p in problems), problems
    layer = layer_of(gdml, "seg_7")
    layer.ring_layout.step[0] *= 0.99
    _, problems = curved_cells_tile(layer)
    assert problems == [f"{layer.name}: variant 'p' on ring 0 reaches 2.558 um outside its cell"]


def _check(data: dict, plant: bool) -> dict:
    from helpers import g4_geometry_check

    return run_in_spawned_process(g4_geometry_check.check_curved, data, plant)


def test_geant4_checks_neighbourhoods_and_finds_a_planted_cell(gdml):
    """The taper's 183 cells are more than 20 placements: Geant4 checks three neighbourhoods of
    cells in a copy of the envelope and each distinct volume below once, and finds nothing; one
    more cell placed half a cell turned from the first overlaps it (and is the last placement,
    a seed of the neighbourhoods)."""
    data = config(gdml, face="seg_7", source_face="seg_7")
    clean = _check(data, False)
    assert clean["ok"], clean["overlaps"]
    assert clean["curved"] == 183
    assert 0 < clean["sampled"] <= 27
    assert len(clean["lines"]) == 1
    assert "183 cells tile the envelope exactly" in clean["lines"][0]
    planted = _check(data, True)
    assert not planted["ok"]
    assert any(o.startswith("planted") for o in planted["overlaps"]), planted["overlaps"]


def test_the_cells_of_sphere_layers_tile_their_envelopes(tmp_path):
    """An orb's outer face and a spherical shell's outer and inner faces (G4Sphere cells)."""
    from test_sphere_rough import config as sphere_config
    from test_sphere_rough import write_spheres

    scene = build_scene(parse_config(sphere_config(write_spheres(tmp_path / "s.gdml"))))
    assert len(scene.layers) == 3
    for layer in scene.layers:
        n, problems = curved_cells_tile(layer)
        assert n == layer.ring_layout.n_cells
        assert problems == [], layer.name
