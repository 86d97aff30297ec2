"""fill: tiles — a patch map made of a small library of random tiles, each placed by native
tiling as one shared group: the right fractions, balanced use of the tiles, few volumes."""

from __future__ import annotations

import numpy as np
import pytest
from test_tiling_nested import spawned

from score4.errors import ConfigError
from score4.geometry.tiling import grouping_plan
from score4.inputs.config import parse_config
from score4.surface import patchmap as pm
from score4.world.resolve import build_scene

from conftest import config_dict


def _tiles_of(grid: np.ndarray, t: int) -> np.ndarray:
    ny, nx = grid.shape
    return grid.reshape(ny // t, t, nx // t, t).transpose(0, 2, 1, 3).reshape(-1, t, t)


def test_tile_size_is_the_first_group_size_of_native_tiling():
    assert pm.tile_cells(2000, 2000) == 40  # 1 m of 0.5 mm cells: 50 x 50 groups of 40 x 40
    assert pm.tile_cells(50, 50) == 1  # fits the envelope: no tiles needed
    assert pm.tile_cells(203, 203) == 5  # 41 x 41 groups
    m = pm.make_patch_map(1000, 0.5, [0.5, 0.5], method="tiles", seed=7)
    assert [(g, len(p)) for g, p, _ in grouping_plan(m.variants)] == [(40, 64)]
    # against fill: random, which shares nothing above 2 x 2 groups (measured: 3 levels)
    random = pm.make_patch_map(1000, 0.5, [0.5, 0.5], method="random", seed=7)
    assert len(grouping_plan(random.variants)) == 3


@pytest.mark.parametrize(("densities", "n_tiles"), [([0.3, 0.5, 0.2], 10), ([0.5, 0.5], 64)])
def test_tiles_keep_the_fractions_and_are_used_equally(densities, n_tiles):
    """A 10 cm face of 0.5 mm cells (200 x 200, tiles of 4 x 4): the library of n_tiles tiles
    has largest-remainder counts over its cells, every tile is used 2500 / n_tiles times (to
    within one), so the face's fractions are the densities to within one cell in the library
    (1 / (16 n_tiles)), not rounded per tile (1 / 16 = 6 %)."""
    m = pm.make_patch_map(100, 0.5, densities, method="tiles", seed=3, n_tiles=n_tiles)
    tiles = _tiles_of(m.variants, 4)
    library, uses = np.unique(tiles, axis=0, return_counts=True)
    assert len(library) == n_tiles
    assert uses.max() - uses.min() <= 1
    lib_counts = np.bincount(library.ravel(), minlength=len(densities))
    assert np.all(np.abs(lib_counts - library.size * np.array(densities)) < 1)
    assert np.all(np.abs(m.fractions - densities) <= 1 / library.size)
    assert m.method == "tiles"
    # the positions of the tiles are random: neighbours along x are not the same tile pattern
    ids = np.unique(tiles, axis=0, return_inverse=True)[1].reshape(50, 50)
    assert (ids[:, 1:] == ids[:, :-1]).mean() < 3 / n_tiles


def test_tiles_map_round_trips_and_describes_itself():
    m = pm.make_patch_map(100, 0.5, [0.3, 0.7], method="tiles", seed=3, n_tiles=5)
    back = pm.PatchMap.from_dict(m.to_dict())
    np.testing.assert_array_equal(back.variants, m.variants)
    assert back.method == "tiles"
    assert "random tiles from a library" in m.describe()


def test_bad_tile_count_is_refused():
    with pytest.raises(ConfigError, match=r"n_tiles: must be a whole number >= 1, got 0"):
        pm.make_patch_map(100, 0.5, [0.5, 0.5], method="tiles", n_tiles=0)
    target = {
        "name": "crystal",
        "material": "G4_Si",
        "size": ["1 mm", "1 mm", "0.1 mm"],
        "position": ["0 mm", "0 mm", "-0.05 mm"],
        "rough": [
            {
                "face": "+z",
                "variants": [{"surface": "p", "density": 1.0}],
                "fill": "tiles",
                "n_tiles": 0,
            }
        ],
    }
    pyr = {"kind": "spikes", "nx": 4, "ny": 4, "width": "10 um", "height": "10 um"}
    with pytest.raises(ConfigError, match=r"n_tiles"):
        build_scene(parse_config(config_dict(surfaces={"p": pyr}, targets=[target])))


def test_tiles_become_shared_group_volumes_in_geant4():
    """30 x 30 cells of 2 variants as tiles of 10 x 10 (an envelope of at most 9 boxes): native
    tiling places one group volume per library tile (4), each cell where one placement per cell
    puts it, with its variant (positions read back from Geant4's volume tree)."""
    rng = np.random.default_rng(5)
    variants = pm._tiled(30, 30, np.array([0.4, 0.6]), 4, rng, max_boxes=9)
    cell = (0.02, 0.03, 0.01)
    out = spawned(variants.tolist(), cell, 9, 10**9)
    assert out["levels"] == [10]
    assert out["logical_volumes"] == 4  # one per tile of the library
    c = np.array(out["cells"])
    i = np.rint((c[:, 1] + 30 * 0.02 / 2) / 0.02 - 0.5).astype(int)
    j = np.rint((c[:, 2] + 30 * 0.03 / 2) / 0.03 - 0.5).astype(int)
    assert len(set(zip(i.tolist(), j.tolist(), strict=True))) == 900
    np.testing.assert_array_equal(c[:, 0].astype(int), variants[j, i])
