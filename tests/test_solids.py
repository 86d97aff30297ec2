"""Geant4 solids and the numpy mesh agree on inside/outside (issue 3, item 6)."""

import sys
from pathlib import Path

import numpy as np
import pytest

from score4.surface.spikes import SpikeGrid

from helpers.spawn import run_in_spawned_process

GRIDS = [
    dict(nx=4, ny=3, width_x=0.01, width_y=0.015, mean_height=0.008, height_sigma=0.002, seed=2),
    dict(
        nx=3, ny=3, width_x=0.01, width_y=0.01, mean_height=0.01, shape="bump", n_layers=5, seed=1
    ),
    dict(
        nx=2, ny=3, width_x=0.012, width_y=0.01, mean_height=0.01, shape="peak", n_layers=4, seed=3
    ),
]
THICKNESS = 0.005


def _classify(points, grid_kwargs):
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_solids import classify

    return classify(points, grid_kwargs, THICKNESS)


@pytest.mark.parametrize("grid_kwargs", GRIDS, ids=["pyramid-gauss", "bump", "peak"])
def test_tessellated_multiunion_and_mesh_agree(grid_kwargs):
    grid = SpikeGrid(**grid_kwargs)
    rng = np.random.default_rng(0)
    n = 3000
    lo = np.array([-grid.size_x / 2 * 1.1, -grid.size_y / 2 * 1.1, -THICKNESS * 1.1])
    hi = np.array([grid.size_x / 2 * 1.1, grid.size_y / 2 * 1.1, grid.heights.max() * 1.1])
    points = lo + rng.uniform(size=(n, 3)) * (hi - lo)
    # Reference from the numpy surface: inside the footprint, above the bottom, below z(x, y).
    in_xy = (np.abs(points[:, 0]) < grid.size_x / 2) & (np.abs(points[:, 1]) < grid.size_y / 2)
    z_top = np.where(
        in_xy,
        grid.height_at(
            np.clip(points[:, 0], -grid.size_x / 2, grid.size_x / 2),
            np.clip(points[:, 1], -grid.size_y / 2, grid.size_y / 2),
        ),
        -np.inf,
    )
    expected = in_xy & (points[:, 2] > -THICKNESS) & (points[:, 2] < z_top)
    tess, union = run_in_spawned_process(_classify, points.tolist(), grid_kwargs)
    tess, union = np.array(tess), np.array(union)
    # Random points land on a surface (within 1e-9 mm) with probability ~0: require exact agreement.
    assert np.array_equal(tess == 2, expected), (
        f"tessellated disagrees on {np.count_nonzero((tess == 2) != expected)} points"
    )
    assert np.array_equal(union == 2, expected), (
        f"multi-union disagrees on {np.count_nonzero((union == 2) != expected)} points"
    )
    assert 0.1 < expected.mean() < 0.9  # the test samples both sides


def _roundtrip(points, grid_kwargs, path):
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_solids import gdml_roundtrip

    return gdml_roundtrip(points, grid_kwargs, THICKNESS, path)


def test_gdml_round_trip_keeps_the_solid(tmp_path):
    grid_kwargs = GRIDS[0]
    grid = SpikeGrid(**grid_kwargs)
    rng = np.random.default_rng(1)
    points = rng.uniform(
        [-grid.size_x / 2, -grid.size_y / 2, -THICKNESS],
        [grid.size_x / 2, grid.size_y / 2, grid.heights.max()],
        (2000, 3),
    )
    path = tmp_path / "rough.gdml"
    before, after, kind, material = run_in_spawned_process(
        _roundtrip, points.tolist(), grid_kwargs, str(path)
    )
    assert kind == "G4TessellatedSolid"
    assert material == "G4_Si"
    assert before == after
    from score4.surface.triangle_mesh import closed_body

    assert path.read_text().count("<triangular ") == closed_body(grid.top_mesh(), THICKNESS).n_faces
    assert [p.name for p in tmp_path.iterdir()] == ["rough.gdml"]
