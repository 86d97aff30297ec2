"""Native tiling in nested groups: every cell box lands where one placement per cell puts it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from score4.geometry.tiling import group_grid, grouping_plan

from helpers.spawn import run_in_spawned_process


def _run(*args):
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers.g4_nested import nested_cells

    return nested_cells(*args)


def spawned(*args):
    return run_in_spawned_process(_run, *args)


def test_group_grid_keeps_every_box_and_shares_equal_groups():
    rng = np.random.default_rng(1)
    ids = rng.integers(0, 2, (7, 9))
    for g in (2, 3, 4):
        patterns, grid = group_grid(ids, g)
        assert grid.shape == (-(-7 // g), -(-9 // g))
        rebuilt = np.concatenate(
            [np.concatenate(list(patterns[row]), axis=1) for row in grid], axis=0
        )
        np.testing.assert_array_equal(rebuilt[:7, :9], ids)
        assert (rebuilt[7:] == -1).all()
        assert (rebuilt[:, 9:] == -1).all()
        assert len({p.tobytes() for p in patterns}) == len(patterns)  # distinct groups


def test_grouping_plan_one_level_for_one_variant_and_two_by_two_where_patterns_repeat():
    assert [g for g, _, _ in grouping_plan(np.zeros((2000, 2000), int))] == [40]
    assert grouping_plan(np.zeros((50, 50), int)) == []  # fits the envelope: no groups
    random = np.random.default_rng(2).integers(0, 3, (300, 300))
    # one level of 6 x 6 groups would need 90 000 placements: above a budget of 50 000
    assert grouping_plan(random, budget=50_000)[0][0] == 2
    assert [g for g, _, _ in grouping_plan(random)] == [6]


@pytest.mark.parametrize(
    ("shape", "n_variants", "max_daughters", "budget"),
    [
        ((23, 37), 3, 4, 10**9),  # one level of 19 x 19 groups, partial groups on both far edges
        ((23, 37), 3, 4, 0),  # 2 x 2 groups at every level: 5 levels, odd edges at each
        ((16, 16), 1, 4, 10**9),  # one variant: a single shared group volume
    ],
)
def test_nested_cells_are_where_one_placement_per_cell_puts_them(
    shape, n_variants, max_daughters, budget
):
    """Positions composed through Geant4's volume tree (translations of every level) against the
    cell centres of the flat layout, exact to 1e-12 mm, with the right variant in every cell."""
    rng = np.random.default_rng(3)
    variants = rng.integers(0, n_variants, shape)
    px, py, t = 0.02, 0.03, 0.01
    out = spawned(variants.tolist(), (px, py, t), max_daughters, budget)
    cells = np.array(out["cells"])
    ny, nx = shape
    assert len(cells) == nx * ny
    # cell (i, j) of the flat layout is centred at (-Lx/2 + (i + 0.5) px, -Ly/2 + (j + 0.5) py)
    i = np.rint((cells[:, 1] + nx * px / 2) / px - 0.5).astype(int)
    j = np.rint((cells[:, 2] + ny * py / 2) / py - 0.5).astype(int)
    assert len(set(zip(i.tolist(), j.tolist(), strict=False))) == nx * ny  # every cell once
    np.testing.assert_allclose(cells[:, 1], -nx * px / 2 + (i + 0.5) * px, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cells[:, 2], -ny * py / 2 + (j + 0.5) * py, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(cells[:, 3], 0.0)
    np.testing.assert_array_equal(cells[:, 0].astype(int), variants[j, i])
    assert out["most_daughters"] <= max(max_daughters, max(g for g in out["levels"]) ** 2)
    if budget == 0:
        assert out["levels"] == [2] * 5
    if n_variants == 1:
        assert out["logical_volumes"] == len(out["levels"]) == 1
    assert out["regions"] == len(out["levels"]) + 1  # one per level of groups, one for the cells
