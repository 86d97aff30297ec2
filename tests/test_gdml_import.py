"""GDML written by another tool (pyg4ometry, not Geant4) read by score4 (issue 3, item 8).

tests/data/gdml/pyg4ometry_tessellated.gdml was written by pyg4ometry 1.4.6 with
tests/data/gdml/make_pyg4ometry_gdml.py; the expected numbers below come from the geometry that
script defines (imported here without pyg4ometry). The round trip score4 write -> read is
covered by test_solids.test_gdml_round_trip_keeps_the_solid.
"""

import importlib.util
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from helpers.spawn import run_in_spawned_process

HERE = Path(__file__).parent
GDML = HERE / "data" / "gdml" / "pyg4ometry_tessellated.gdml"


def _load_generator():
    spec = importlib.util.spec_from_file_location(
        "make_pyg4ometry_gdml", HERE / "data" / "gdml" / "make_pyg4ometry_gdml.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


GEN = _load_generator()
CELL, H, THICK = GEN.CELL, GEN.HEIGHTS, GEN.THICKNESS
HALF = 1.5 * CELL  # half side of the slab


def top_height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Height of the pyramid surface at (x, y) inside the footprint (solid frame)."""
    i = np.clip(np.floor((x + HALF) / CELL).astype(int), 0, 2)
    j = np.clip(np.floor((y + HALF) / CELL).astype(int), 0, 2)
    cx, cy = -HALF + CELL * (i + 0.5), -HALF + CELL * (j + 0.5)
    return H[j, i] * (1 - np.maximum(np.abs(x - cx), np.abs(y - cy)) / (CELL / 2))


def expected_inside(p: np.ndarray) -> np.ndarray:
    x, y, z = p.T
    in_xy = (np.abs(x) < HALF) & (np.abs(y) < HALF)
    return in_xy & (z > -THICK) & (z < np.where(in_xy, top_height(x, y), -np.inf))


def _inspect(path, solid_points, world_points):
    sys.path.insert(0, str(HERE))
    from helpers.g4_gdml_import import inspect_gdml

    return inspect_gdml(path, solid_points, world_points)


# Points with a known answer (solid frame): 2 inside, 1 on the surface, 0 outside.
KNOWN = [
    ((0.0, 0.0, -2.5), 2),  # middle of the slab
    ((-10.0, -10.0, 2.99), 2),  # just under the apex of the first pyramid (h = 3)
    ((-10.0, -10.0, 3.01), 0),  # just above it
    ((0.0, 10.0, 8.99), 2),  # under the tallest apex (h = 9)
    ((10.0, 10.0, 1.01), 0),  # above the lowest apex (h = 1)
    ((5.0, 0.0, 0.5), 0),  # over the valley between two pyramids
    ((-10.0, -10.0, 3.0), 1),  # an apex
    ((5.0, 0.0, 0.0), 1),  # a valley line between pyramids (z = 0)
    ((15.0, 0.0, -2.5), 1),  # a wall
    ((0.0, 0.0, -5.0), 1),  # the bottom
    ((0.0, 0.0, -5.01), 0),  # below it
    ((15.01, 0.0, -2.5), 0),  # beside a wall
]


@pytest.fixture(scope="module")
def report():
    rng = np.random.default_rng(5)
    random_points = rng.uniform([-16, -16, -6], [16, 16, 10], (3000, 3))
    solid_points = [p for p, _ in KNOWN] + random_points.tolist()
    world_points = (random_points[:300] + np.array(GEN.PLACEMENT)).tolist()
    out = run_in_spawned_process(_inspect, str(GDML), solid_points, world_points)
    out["random_points"] = random_points
    return out


def test_file_is_pyg4ometry_output_as_documented():
    root = ET.parse(GDML).getroot()
    tess = root.find("solids/tessellated")
    assert tess.get("name") == "rough"
    assert len(tess.findall("triangular")) == 36
    assert len(tess.findall("quadrangular")) == 21
    vertices, facets = GEN.rough_body()
    assert GEN.check(vertices, facets) == pytest.approx(6000.0)


def test_structure_materials_and_placement(report):
    assert report["n_daughters"] == 1
    assert report["pv_name"] == "rough_pv"
    assert report["world_half"] == pytest.approx(
        [w / 2 for w in GEN.WORLD]
    )  # GDML box: full lengths
    assert report["world_material"] == "G4_Galactic"
    assert report["material"] == "G4_Si"
    assert report["translation"] == pytest.approx(list(GEN.PLACEMENT))


def test_tessellated_solid_matches_the_definition(report):
    assert report["type"] == "G4TessellatedSolid"
    assert report["n_facets"] == 57
    assert sorted(report["facet_vertices"]) == [3] * 36 + [4] * 21
    # Exact for a tessellated solid (sum over facets), so a tight tolerance.
    assert report["volume"] == pytest.approx(
        HALF * 2 * HALF * 2 * THICK + CELL**2 / 3 * H.sum(), rel=1e-12
    )
    lateral = 4 * 0.5 * CELL * np.sqrt(H**2 + (CELL / 2) ** 2)  # four triangles per pyramid
    area = (2 * HALF) ** 2 + 4 * (2 * HALF) * THICK + lateral.sum()
    assert report["area"] == pytest.approx(area, rel=1e-12)
    np.testing.assert_allclose(
        report["limits"], [[-HALF, -HALF, -THICK], [HALF, HALF, H.max()]], rtol=1e-12
    )


def test_inside_outside_on_known_and_random_points(report):
    codes = np.array(report["inside"])
    assert codes[: len(KNOWN)].tolist() == [c for _, c in KNOWN]
    random_codes = codes[len(KNOWN) :]
    expected = expected_inside(report["random_points"])
    # Random points lie on a facet with probability ~0: require exact agreement.
    assert np.array_equal(random_codes == 2, expected), (
        f"{np.count_nonzero((random_codes == 2) != expected)} points differ"
    )
    assert 0.2 < expected.mean() < 0.8


def test_navigator_finds_the_placed_volume(report):
    expected = expected_inside(report["random_points"][:300])
    found = np.array([name == "rough_pv" for name in report["located"]])
    assert np.array_equal(found, expected)
    assert set(report["located"]) == {"rough_pv", "world_lv_PV"}  # Geant4's name for the world
