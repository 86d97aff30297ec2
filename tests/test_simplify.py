"""Simplified meshes of height maps (``tolerance:``): every map sample within the tolerance, the
exact mesh at 0, blocks still cut the body exactly, and alphas see the same spectrum."""

from __future__ import annotations

from pathlib import Path

import matplotlib.tri as mtri
import numpy as np
import pytest
from scipy import stats

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.surface import block_cut as blk
from score4.surface import rough as rough_module
from score4.surface.simplify import simplified_mesh
from score4.surface.spec import build_surface
from score4.surface.triangle_mesh import (
    closed_body,
    degenerate_faces,
    from_heightmap,
    is_watertight,
    signed_volume,
)

from conftest import TARGET, config_dict

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "surfaces"
# 80 x 80 pixels of 0.5 um (a periodic map gets its first row and column again): 5 x 5 patches
# on TARGET's 0.2 mm face
RUN_MAP = {"nx": 80, "ny": 80, "periodic": True}
GAUSS = {
    "kind": "random",
    "nx": 70,  # 69 x 52 pixels: no power of two, quads clipped at two edges
    "ny": 53,
    "pitch": "0.5 um",
    "sq": "0.3 um",
    "corr_length": "3 um",
    "periodic": False,
    "seed": 1,
}
MEASURED = {
    "kind": "measured",
    "file": str(EXAMPLES / "turned_grid.txt"),
    "crop_x": ["1 um", "39 um"],
}


def _map_error(mesh, hm) -> float:
    """Largest |z_mesh - z_map| at the map's samples, by matplotlib's own linear interpolation
    on the mesh's triangles (not score4's)."""
    tri = mtri.Triangulation(mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.faces)
    xx, yy = np.meshgrid(hm.x, hm.y)
    z = mtri.LinearTriInterpolator(tri, mesh.vertices[:, 2])(xx, yy)
    assert np.ma.count_masked(z) == 0  # the mesh covers the whole map
    return float(np.abs(z - hm.heights).max())


@pytest.mark.parametrize("spec", [GAUSS, MEASURED], ids=["gauss", "measured"])
@pytest.mark.parametrize("tol_um", [0.003, 0.03, 0.1, 0.3])
def test_every_map_sample_lies_within_the_tolerance(spec, tol_um):
    surface = build_surface({**spec, "tolerance": f"{tol_um} um"})
    mesh, hm = surface.top_mesh, surface.placed_map
    assert surface.mesh_tolerance == pytest.approx(tol_um * 1e-3)
    err = _map_error(mesh, hm)
    assert err <= tol_um * 1e-3 * (1 + 1e-9), err
    exact = build_surface({**spec, "tolerance": 0}).top_mesh
    assert mesh.n_faces <= exact.n_faces
    if tol_um >= 0.1:  # these smooth maps simplify (measured: 3-10x fewer facets at 0.1 um)
        assert mesh.n_faces < exact.n_faces / 2
    # a height field over the whole patch, no sliver, the same outline
    assert (mesh.projected_areas > 0).all()
    assert len(degenerate_faces(mesh)) == 0
    assert mesh.projected_areas.sum() == pytest.approx(hm.size_x * hm.size_y, rel=1e-12)
    assert is_watertight(closed_body(mesh, 1e-3))


def test_zero_tolerance_is_the_exact_mesh():
    surface = build_surface({**GAUSS, "tolerance": 0})
    exact = from_heightmap(surface.placed_map)
    assert surface.mesh_tolerance == 0
    assert surface.quad_cells is None
    assert np.array_equal(surface.top_mesh.vertices, exact.vertices)
    assert np.array_equal(surface.top_mesh.faces, exact.faces)
    # a tolerance below every deviation also keeps every sample: all quads of one pixel
    tiny = simplified_mesh(surface.placed_map, 1e-15)
    assert tiny.n_faces == exact.n_faces
    assert _map_error(tiny, surface.placed_map) <= 1e-15


def test_auto_keeps_small_maps_exact_and_simplifies_large_ones(monkeypatch):
    """``tolerance: auto``: exact up to AUTO_EXACT_FACETS triangles, above it 1 % of the map's
    height or 0.1 um, whichever is larger (the rule of issue 24 for rough curved layers)."""
    small = build_surface(GAUSS)
    assert small.mesh_tolerance == 0
    monkeypatch.setattr(rough_module, "AUTO_EXACT_FACETS", 1000)
    large = build_surface(GAUSS)
    assert large.mesh_tolerance == pytest.approx(max(0.01 * large.max_height, 1e-4))
    steep = build_surface({**GAUSS, "sq": "3 um", "corr_length": "20 um", "pitch": "2 um"})
    assert steep.mesh_tolerance == pytest.approx(0.01 * steep.max_height)
    assert steep.mesh_tolerance > 1e-4


def test_auto_keeps_a_noise_like_map_exact(monkeypatch):
    """``tolerance: auto`` on a map that hardly simplifies (correlation length 2 pixels, the
    shortest allowed) keeps the exact mesh, whose blocks build cheaper than its cut-down
    simplified ones; the same map with the tolerance given is simplified as asked."""
    noise = {**GAUSS, "corr_length": "1 um"}
    monkeypatch.setattr(rough_module, "AUTO_EXACT_FACETS", 1000)
    tolerance = max(0.01 * build_surface(noise).max_height, 1e-4)
    given = build_surface({**noise, "tolerance": f"{tolerance * 1e3} um"})
    exact_faces = 2 * 69 * 52
    assert given.top_mesh.n_faces > rough_module.AUTO_MIN_SAVING * exact_faces
    auto = build_surface(noise)
    assert auto.mesh_tolerance == 0
    assert auto.quad_cells is None
    assert auto.top_mesh.n_faces == exact_faces
    smooth = build_surface(GAUSS)  # the Gaussian map saves more than half: simplified
    assert smooth.mesh_tolerance > 0
    assert smooth.top_mesh.n_faces < rough_module.AUTO_MIN_SAVING * exact_faces


def test_blocks_of_a_simplified_map_cut_its_body_exactly():
    """Quads never cross a block edge: each block is closed, and the blocks' volumes add up to
    the simplified body's."""
    surface = build_surface({**GAUSS, "tolerance": "0.1 um"})
    q = surface.quad_cells
    assert q is not None
    assert q & (q - 1) == 0
    bodies = blk.block_bodies(surface, 1e-3)
    rects = blk.block_rects(surface, None)[1]
    assert len(bodies) == len(rects)
    # the blocks tile the grid: no cell in two blocks, none in none
    ny, nx = blk.cell_shape(surface)
    cover = np.zeros((ny, nx), int)
    for i0, i1, j0, j1 in rects:
        cover[j0:j1, i0:i1] += 1
    assert (cover == 1).all()
    assert all(is_watertight(b) for b in bodies)
    assert sum(b.top.sum() for b in bodies) == surface.top_mesh.n_faces
    whole = signed_volume(closed_body(surface.top_mesh, 1e-3))
    assert sum(signed_volume(b) for b in bodies) == pytest.approx(whole, rel=1e-12)


def test_dense_blocks_of_a_simplified_map_are_cut_down_to_their_quads(monkeypatch):
    """A block with more than SIMPLIFIED_BLOCK_FACETS top faces is cut in four unless a face
    would cross a cut: where the map is rough the blocks then hold few facets each. Every face
    stays inside its block's cells."""
    surface = build_surface({**GAUSS, "tolerance": "0.1 um"})
    q = surface.quad_cells
    limit = 16  # the test map's quad-side blocks hold up to ~100 faces
    monkeypatch.setattr(blk, "SIMPLIFIED_BLOCK_FACETS", 10**9)
    whole_block, whole_rects = blk.block_rects(surface, None)
    assert (whole_rects[:, 1] - whole_rects[:, 0] <= q).all()
    assert np.bincount(whole_block).max() > limit
    monkeypatch.setattr(blk, "SIMPLIFIED_BLOCK_FACETS", limit)
    block, rects = blk.block_rects(surface, None)
    per_block = np.bincount(block)
    assert len(rects) > len(whole_rects)
    mesh, hm = surface.top_mesh, surface.placed_map
    fi = np.searchsorted(hm.x, mesh.vertices[:, 0])[mesh.faces]
    fj = np.searchsorted(hm.y, mesh.vertices[:, 1])[mesh.faces]
    for b in np.flatnonzero(per_block > limit):  # each could not be cut: a face crosses a cut
        i0, i1, j0, j1 = rects[b]
        rows = block == b
        im, jm = (i0 + i1) // 2, (j0 + j1) // 2
        crossing = (fi[rows].min(1) < im) & (fi[rows].max(1) > im)
        crossing |= (fj[rows].min(1) < jm) & (fj[rows].max(1) > jm)
        assert crossing.any() or min(i1 - i0, j1 - j0) < 2
    _assert_blocks_hold_their_faces(surface, fi, fj, block, rects)


def _assert_blocks_hold_their_faces(surface, fi, fj, block, rects) -> None:
    """Every top face (pixel columns ``fi``, rows ``fj`` of its corners) lies in its block's
    rectangle, and the blocks' bodies are watertight and make the map's body (volume 1e-12)."""
    assert (fi.min(1) >= rects[block, 0]).all()
    assert (fi.max(1) <= rects[block, 1]).all()
    assert (fj.min(1) >= rects[block, 2]).all()
    assert (fj.max(1) <= rects[block, 3]).all()
    bodies = blk.block_bodies(surface, 1e-3)
    assert len(bodies) == len(rects)
    assert all(is_watertight(b) for b in bodies)
    whole = signed_volume(closed_body(surface.top_mesh, 1e-3))
    assert sum(signed_volume(b) for b in bodies) == pytest.approx(whole, rel=1e-12)


def test_dense_blocks_of_a_large_simplified_map_are_cut_in_two(monkeypatch):
    """Above SPLIT_IN_TWO_FACETS top facets a dense block is cut in two across its longer side
    instead of in four: fewer blocks, each of at most SIMPLIFIED_BLOCK_FACETS top faces unless
    a face would cross the cut, and the blocks still tile the map and make its body."""
    surface = build_surface({**GAUSS, "tolerance": "0.1 um"})
    limit = 16
    monkeypatch.setattr(blk, "SIMPLIFIED_BLOCK_FACETS", limit)
    _, fours = blk.block_rects(surface, None)
    monkeypatch.setattr(blk, "SPLIT_IN_TWO_FACETS", surface.top_mesh.n_faces - 1)
    block, rects = blk.block_rects(surface, None)
    assert len(rects) < len(fours)
    mesh, hm = surface.top_mesh, surface.placed_map
    fi = np.searchsorted(hm.x, mesh.vertices[:, 0])[mesh.faces]
    fj = np.searchsorted(hm.y, mesh.vertices[:, 1])[mesh.faces]
    per_block = np.bincount(block, minlength=len(rects))
    for b in np.flatnonzero(per_block > limit):  # each could not be cut: a face crosses the cut
        i0, i1, j0, j1 = rects[b]
        rows = block == b
        if i1 - i0 >= j1 - j0:
            mid = (i0 + i1) // 2
            crossing = (fi[rows].min(1) < mid) & (fi[rows].max(1) > mid)
        else:
            mid = (j0 + j1) // 2
            crossing = (fj[rows].min(1) < mid) & (fj[rows].max(1) > mid)
        assert crossing.any() or max(i1 - i0, j1 - j0) < 2
    _assert_blocks_hold_their_faces(surface, fi, fj, block, rects)


def test_tolerance_input_is_checked():
    assert build_surface({**GAUSS, "tolerance": "50 nm"}).mesh_tolerance == pytest.approx(5e-5)
    for bad in ("-1 um", "fine", "3"):
        with pytest.raises(ConfigError, match="tolerance"):
            build_surface({**GAUSS, "tolerance": bad})
    surface = build_surface({**GAUSS, "tolerance": "0.1 um"})
    with pytest.raises(ConfigError, match=r"block_cells: 3 is not allowed on a simplified"):
        blk.check_patch(surface, "blocks", 3)


def test_run_record_gives_the_tolerance_and_facets(tmp_path):
    surface = {**GAUSS, **RUN_MAP, "tolerance": "0.1 um"}
    data = _alpha_run(surface, 20, 1)
    r = run(parse_config(data), tmp_path / "a.h5", progress=False, echo=lambda m: None)
    meshes = read_results(r).run["map_meshes"]
    facets = build_surface(surface).top_mesh.n_faces
    assert list(meshes.values()) == [{"tolerance_um": [0.1], "top_facets": [facets]}]


def _alpha_run(surface: dict, events: int, seed: int) -> dict:
    target = {**TARGET, "rough": [{"face": "+z", "surface": "s", "solid": "blocks"}]}
    source = {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "crystal", "face": "+z"},
        "depth": {"profile": "exponential", "mean": "20 nm"},
    }
    data = config_dict(surfaces={"s": surface}, targets=[target], source=source)
    data["run"] = {"events": events, "seed": seed}
    return data


@pytest.mark.deep  # ~15 s CPU
@pytest.mark.parametrize("events", [3000])
def test_alpha_spectra_of_exact_and_simplified_maps_agree(tmp_path, events):
    """``events`` alphas (5.3 MeV, 20 nm below a Gaussian map of 2.6 um peak to valley,
    isotropic) on the exact mesh and on its 0.1 um simplification, independent seeds: two-sample
    KS p > 0.01 (a KS distance below 1.63 sqrt(2 / events): 0.042 for 3000 events). Measured:
    p = 0.19 (12 800 exact top facets, 2164 simplified; mean deposit 2.54 and 2.47 MeV); a
    deliberately coarse 1 um tolerance (69 facets, the map nearly flat) gives p = 0.001 and
    fails it."""
    spec = {**GAUSS, **RUN_MAP}
    out = {}
    for tol, seed in ((0, 1), ("0.1 um", 2)):
        data = _alpha_run({**spec, "tolerance": tol}, events, seed)
        r = run(parse_config(data), tmp_path / f"{seed}.h5", progress=False, echo=lambda m: None)
        out[tol] = read_results(r).edep["crystal"]
    assert len(out[0]) == len(out["0.1 um"]) == events
    p = stats.ks_2samp(out[0], out["0.1 um"]).pvalue
    assert p > 0.01, p


def test_geantinos_straight_down_through_cut_simplified_blocks(monkeypatch):
    """A simplified map's blocks cut down to few facets (SIMPLIFIED_BLOCK_FACETS set to 8: blocks
    of two sizes side by side, each on its floor) give 400 geantinos straight down
    at random points the exact mesh height + slab + box, as test_blocks asks of equal blocks:
    all within 1e-6 mm, 99 % within 1e-9 mm. A gap, an overlap or a lost block between blocks
    of different sizes changes a path by up to the map's height."""
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.simulation import Simulation
    from score4.source.primaries import Primaries
    from score4.world.resolve import build_scene

    monkeypatch.setattr(blk, "SIMPLIFIED_BLOCK_FACETS", 8)
    surface = {**GAUSS, **RUN_MAP, "tolerance": "0.1 um"}
    target = {**TARGET, "rough": [{"face": "+z", "surface": "s", "solid": "blocks"}]}
    source = {"particle": "geantino", "energy": "1 MeV", "surface": {"volume": "crystal"}}
    data = config_dict(surfaces={"s": surface}, targets=[target], source=source)
    data["output"] = {"track_length": True}
    config = parse_config(data)
    sizes = np.unique(np.diff(blk.block_rects(build_surface(surface), None)[1][:, :2]))
    assert len(sizes) >= 2  # blocks of different sizes meet
    n = 400
    rng = np.random.default_rng(3)
    pos = np.column_stack([rng.uniform(-0.099, 0.099, (n, 2)), np.full(n, 0.02)])
    primaries = Primaries(
        event=np.arange(n),
        particle=np.full(n, "geantino"),
        energy=np.ones(n),
        position=pos,
        direction=np.tile([0.0, 0.0, -1.0], (n, 1)),
    )
    sim = Simulation(plan_run(config, physics=resolve_physics("lite")))
    paths = sim.run(primaries, 1)["track_length"][:, sim.volumes.index("crystal")]
    # the simplified mesh's height under each ray (matplotlib's interpolation of the mesh) +
    # slab + box
    layer = build_scene(config).layers[0]
    i, j = layer.patch_map.cell_of(pos[:, :2])
    local = pos[:, :2] - layer.cell_centres()[j, i]
    mesh = layer.variants[0].top_mesh
    tri = mtri.Triangulation(mesh.vertices[:, 0], mesh.vertices[:, 1], mesh.faces)
    height = mtri.LinearTriInterpolator(tri, mesh.vertices[:, 2])(local[:, 0], local[:, 1])
    exact = np.asarray(height) + layer.base_thickness + config.targets[0].size[2]
    err = np.abs(paths - exact)
    assert err.max() < 1e-6
    assert (err > 1e-9).mean() < 0.01
