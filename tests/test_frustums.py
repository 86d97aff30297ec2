"""solid: frustums — a spike grid's base box and frustums placed side by side is the multi-union's
body: the same geantino paths, and straight-down rays see the exact mesh height."""

from __future__ import annotations

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import auto_solid, parse_config
from score4.source.build import make_source
from score4.source.primaries import Primaries
from score4.world.resolve import build_scene

from conftest import SPREAD, TARGET, config_dict, crystal_track_lengths, straight_down_paths
from helpers.spawn import run_in_spawned_process

PYRAMIDS = {**SPREAD, "shape": "pyramid", "n_layers": 1, "seed": 7}
RANDOM = {
    "kind": "random",
    "nx": 20,
    "ny": 20,
    "pitch": "2.5 um",
    "sq": "1 um",
    "corr_length": "8 um",
    "seed": 2,
}


def _data(surface: dict, solid: str = "auto") -> dict:
    target = {**TARGET, "rough": [{"face": "+z", "surface": "s", "solid": solid}]}
    source = {
        "particle": "geantino",
        "energy": "1 MeV",
        "surface": {"volume": "crystal", "face": "+z"},
        "depth": {"profile": "exponential", "mean": "0.5 um"},
    }
    return config_dict(surfaces={"s": surface}, targets=[target], source=source)


def test_auto_takes_frustums_for_spike_grids_with_a_spread_or_layers():
    """Auto: a multi-union for equal single-layer spikes (pyramids) only; frustums for a height
    spread and for spikes of several layers (here bumps of 3), blocks for a height map; the
    config's auto_solid says the same before building."""
    kinds = {}
    equal = {k: v for k, v in SPREAD.items() if k != "seed"} | {"height_sigma": "0 um"}
    pyramids = {k: v for k, v in equal.items() if k not in ("shape", "n_layers")}
    surfaces = (("spread", SPREAD), ("equal", equal), ("pyramids", pyramids), ("random", RANDOM))
    for name, surface in surfaces:
        config = parse_config(_data(surface))
        kinds[name] = build_scene(config).layers[0].solid_kind(0)
        assert auto_solid(config.surfaces["s"]) == kinds[name]
    assert kinds == {
        "spread": "frustums",
        "equal": "frustums",
        "pyramids": "multiunion",
        "random": "blocks",
    }


def test_frustums_of_a_height_map_are_refused():
    with pytest.raises(ConfigError, match=r"solid frustums needs a spike-grid surface; 's'"):
        build_scene(parse_config(_data(RANDOM, "frustums"))).layers[0].solid_kind(0)


def _rays(config, n: int = 300) -> Primaries:
    """Geantinos straight down, oblique, grazing and horizontal inside the layer, and isotropic
    from sampled vertices below the surface."""
    rng = np.random.default_rng(3)
    scene = build_scene(config)
    layer = scene.layers[0]
    lu, lv = layer.frame.size
    top = layer.thickness + 1e-4
    pos, dirs = [], []
    xy = rng.uniform([-lu / 2, -lv / 2], [lu / 2, lv / 2], (n, 2))
    pos.append(np.column_stack([xy, np.full(n, top)]))
    dirs.append(np.tile([0.0, 0, -1], (n, 1)))
    for cz_lo, cz_hi in ((0.3, 0.9), (1e-3, 0.05)):
        phi, cz = rng.uniform(0, 2 * np.pi, n), rng.uniform(cz_lo, cz_hi, n)
        s = np.sqrt(1 - cz**2)
        dirs.append(np.column_stack([s * np.cos(phi), s * np.sin(phi), -cz]))
        pos.append(np.column_stack([rng.uniform(-lu / 2, lu / 2, (n, 2)), rng.uniform(0, top, n)]))
    phi = rng.uniform(0, 2 * np.pi, n)
    z0 = layer.base_thickness + rng.uniform(0, 1, n) * (layer.thickness - layer.base_thickness)
    dirs.append(np.column_stack([np.cos(phi), np.sin(phi), np.zeros(n)]))
    pos.append(np.column_stack([rng.uniform(-lu / 2, lu / 2, (n, 2)), z0]))
    src = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    pos.append(src.position)
    dirs.append(rng.normal(size=(n, 3)))
    p, d = np.concatenate(pos), np.concatenate(dirs)
    d /= np.linalg.norm(d, axis=1)[:, None]
    return Primaries(
        event=np.arange(len(p)),
        particle=np.full(len(p), "geantino"),
        energy=np.ones(len(p)),
        position=p,
        direction=d,
    )


@pytest.mark.parametrize("surface", [SPREAD, PYRAMIDS], ids=["bumps", "pyramids"])
def test_geantino_paths_through_frustums_match_the_multiunion(tmp_path, surface):
    """1500 geantinos through 2 x 2 patches (the face holds 4 x 5 bumps or pyramids per patch
    with a 2 um height spread) as the multi-union and as placed frustums: the path lengths in the
    crystal group (box + patches) agree to 1e-9 mm on every ray, and rays straight down equal the
    exact mesh height + slab + box to 1e-9 mm. A missing, misplaced or mis-sized frustum, or a
    base box off by its thickness, changes such paths by microns."""
    data = {m: _data(surface, m) for m in ("multiunion", "frustums")}
    config = parse_config(data["multiunion"])
    primaries = _rays(config)
    out = crystal_track_lengths(tmp_path, data, primaries)
    np.testing.assert_allclose(out["frustums"], out["multiunion"], rtol=0, atol=1e-9)
    down, exact = straight_down_paths(config, primaries)
    np.testing.assert_allclose(out["frustums"][down], exact, rtol=0, atol=1e-9)
    assert (out["frustums"] > 0).mean() > 0.6  # most rays cross material


def _spawned(function, *args):
    return run_in_spawned_process(_call, function, *args)


def _call(function, *args):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from helpers import g4_regions

    return getattr(g4_regions, function)(*args)


def test_the_unused_parallel_world_region_is_dropped_and_results_do_not_change():
    """Geant4 walks every placed volume (every frustum) before each BeamOn for a region that is
    not in the world; score4 removes the only such region, DefaultRegionForParallelWorld (a
    10 cm frustum face: 0.27 s -> 0.3 ms per BeamOn, bench_runloop.py). The region store no
    longer holds it, and 300 alpha events deposit exactly what they deposit with it."""
    data = config_dict(
        surfaces={"s": PYRAMIDS},
        targets=[
            {
                "name": "crystal",
                "material": "G4_Si",
                "size": ["0.1 mm", "0.08 mm", "0.1 mm"],  # 2 x 2 patches of 50 x 40 um
                "position": ["0 mm", "0 mm", "-0.05 mm"],
                "rough": [{"face": "+z", "surface": "s", "solid": "frustums"}],
            }
        ],
        source={
            "particle": "alpha",
            "energy": "5.3 MeV",
            "surface": {"volume": "crystal", "face": "+z"},
            "depth": {"profile": "exponential", "mean": "20 nm"},
        },
    )
    data["run"] = {"events": 300, "seed": 3}
    dropped, edep = _spawned("region_and_deposits", data, 3, False)
    kept, edep_kept = _spawned("region_and_deposits", data, 3, True)
    assert (dropped, kept) == (False, True)
    assert edep.shape == (300, 1)
    np.testing.assert_array_equal(edep, edep_kept)
