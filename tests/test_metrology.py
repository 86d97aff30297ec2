"""ISO 25178-2 metrology: analytic spike grids, mesh-exact vs sampled, and surfalize as a
reference."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import integrate

from score4.errors import ConfigError
from score4.surface.heightmap import HeightMap
from score4.surface.metrology import (
    MESH_PARAMETERS,
    PARAMETERS,
    areal_parameters,
    autocorrelation,
    level,
    mesh_parameters,
)
from score4.surface.spikes import SpikeGrid
from score4.surface.triangle_mesh import TriangleMesh, from_heightmap


def gaussian_field(ny: int, nx: int, lx: float, ly: float, seed: int) -> np.ndarray:
    """Unit-variance periodic Gaussian random field with ACF exp(-(x/lx)² - (y/ly)²) (pixels)."""
    rng = np.random.default_rng(seed)
    ky, kx = np.fft.fftfreq(ny)[:, None], np.fft.fftfreq(nx)[None, :]
    # |filter|² = exp(-pi² (kx lx)² - pi² (ky ly)²) is the Fourier transform of that ACF.
    filt = np.exp(-((np.pi * kx * lx) ** 2) / 2 - (np.pi * ky * ly) ** 2 / 2)
    z = np.fft.ifft2(np.fft.fft2(rng.normal(size=(ny, nx))) * filt).real
    return z / z.std()


def periodic_samples(grid: SpikeGrid, per_cell: int) -> HeightMap:
    """Exact samples of a spike grid, one period per cell, without the duplicated far edge."""
    hm = grid.to_heightmap((grid.width_x / per_cell, grid.width_y / per_cell))
    return HeightMap(hm.heights[:-1, :-1], hm.pitch_x, hm.pitch_y)


# --- the parameter table ------------------------------------------------------------------


def test_parameter_table_matches_outputs():
    symbols = [p[0] for p in PARAMETERS]
    assert len(set(symbols)) == len(symbols)
    assert {p[1] for p in PARAMETERS} <= {"length", "ratio", "percent"}
    hm = HeightMap(gaussian_field(32, 40, 3, 3, 0) * 1e-3, 1e-3, 1e-3)
    assert list(areal_parameters(hm)) == symbols
    assert list(mesh_parameters(from_heightmap(hm))) == list(MESH_PARAMETERS)
    assert set(MESH_PARAMETERS) <= set(symbols)


# --- analytic spike grids -----------------------------------------------------------------
#
# Pyramid of height h over a w_x x w_y cell: the horizontal section at height z is the cell
# scaled by (1 - z/h) about its centre, so the fraction of projected area with height >= z is
# (1 - z/h)². The height density over projected area is therefore p(z) = 2 (h - z) / h²,
# i.e. u = z/h ~ Beta(1, 2), with raw moments E[u^k] = 2 / ((k + 1)(k + 2)):
#   mean = h/3, variance = h²/6 - h²/9 = h²/18          -> Sq  = h / sqrt(18)
#   E[(u - 1/3)³] = 1/10 - 3(1/3)(1/6) + 2/27 = 1/135   -> Ssk = (1/135) / 18^-1.5 = 2 sqrt(2) / 5
#   E[(u - 1/3)⁴] = 1/15 - 4(1/3)(1/10) + 6(1/9)(1/6) - 3/81 = 1/135 -> Sku = 18² / 135 = 2.4
#   E|u - 1/3| = 2 ∫_{1/3}^1 (u - 1/3) 2 (1 - u) du = 16/81 -> Sa = 16 h / 81
#   Sp = h - h/3 = 2h/3, Sv = h/3, Sz = h.
# Two faces (facing ±y) have slope 2h/w_y, two (facing ±x) 2h/w_x, each over a quarter of the
# cell: Sdq² = ((2h/w_x)² + (2h/w_y)²) / 2; the four faces' true area is
# w_x sqrt(w_y²/4 + h²) + w_y sqrt(w_x²/4 + h²).


def pyramid_grid_expected(h: float, wx: float, wy: float) -> dict[str, float]:
    area = wx * math.sqrt(wy**2 / 4 + h**2) + wy * math.sqrt(wx**2 / 4 + h**2)
    return {
        "Sa": 16 * h / 81,
        "Sq": h / math.sqrt(18),
        "Sp": 2 * h / 3,
        "Sv": h / 3,
        "Sz": h,
        "Ssk": 2 * math.sqrt(2) / 5,
        "Sku": 2.4,
        "Sdq": math.sqrt(((2 * h / wx) ** 2 + (2 * h / wy) ** 2) / 2),
        "Sdr": (area / (wx * wy) - 1) * 100,
    }


@pytest.mark.parametrize("level", [True, False])
def test_pyramid_grid_mesh_is_exact(level):
    g = SpikeGrid(nx=5, ny=3, width_x=0.004, width_y=0.0025, mean_height=0.003)
    got = mesh_parameters(g.top_mesh(), level=level)
    expected = pyramid_grid_expected(0.003, 0.004, 0.0025)
    for key, value in expected.items():
        assert got[key] == pytest.approx(value, rel=1e-12), key


def test_random_height_pyramids_moments():
    # Mixture over equal-area cells: E[z^k] = mean(h^k) * 2 / ((k + 1)(k + 2)).
    g = SpikeGrid(nx=7, ny=4, width_x=1.0, width_y=2.0, mean_height=1.0, height_sigma=0.3, seed=5)
    h = g.heights.ravel()
    raw = [np.mean(h**k) * 2 / ((k + 1) * (k + 2)) for k in range(5)]
    m = raw[1]
    c2 = raw[2] - m**2
    c3 = raw[3] - 3 * m * raw[2] + 2 * m**3
    c4 = raw[4] - 4 * m * raw[3] + 6 * m**2 * raw[2] - 3 * m**4
    got = mesh_parameters(g.top_mesh(), level=False)
    assert got["Sq"] == pytest.approx(math.sqrt(c2), rel=1e-12)
    assert got["Ssk"] == pytest.approx(c3 / c2**1.5, rel=1e-11)
    assert got["Sku"] == pytest.approx(c4 / c2**2, rel=1e-12)
    assert got["Sp"] == pytest.approx(h.max() - m, rel=1e-12)
    assert got["Sv"] == pytest.approx(m, rel=1e-12)


def test_many_layer_bump_converges_to_the_smooth_profile():
    # Smooth bump: area fraction above u = z/h is (1 - u²)², density p(u) = 4 u (1 - u²),
    # raw moments E[u^k] = 4/(k+2) - 4/(k+4). The layer error falls as 1/n² (Ssk: 1.3e-2,
    # 3.3e-3, 8.3e-4 absolute at 12, 24, 48 layers); at 48 the others are within 1e-3 relative.
    g = SpikeGrid(nx=2, ny=3, width_x=1.0, width_y=1.5, mean_height=1.0, shape="bump", n_layers=48)
    got = mesh_parameters(g.top_mesh(), level=False)
    raw = [4 / (k + 2) - 4 / (k + 4) for k in range(5)]
    m = raw[1]
    c2 = raw[2] - m**2
    c3 = raw[3] - 3 * m * raw[2] + 2 * m**3
    c4 = raw[4] - 4 * m * raw[3] + 6 * m**2 * raw[2] - 3 * m**4
    sa = integrate.quad(lambda u: abs(u - m) * 4 * u * (1 - u * u), 0, 1, points=[m])[0]
    assert got["Sa"] == pytest.approx(sa, rel=1e-3)
    assert got["Sq"] == pytest.approx(math.sqrt(c2), rel=1e-3)
    assert got["Ssk"] == pytest.approx(c3 / c2**1.5, abs=2e-3)  # Ssk ~ -0.13: absolute
    assert got["Sku"] == pytest.approx(c4 / c2**2, rel=1e-3)


# --- mesh-exact versus sampled --------------------------------------------------------------


def test_mesh_exact_agrees_with_fine_sampling():
    g = SpikeGrid(
        nx=4,
        ny=3,
        width_x=2.0,
        width_y=1.0,
        mean_height=1.0,
        height_sigma=0.2,
        seed=3,
        shape="bump",
        n_layers=5,
    )
    exact = mesh_parameters(g.top_mesh(), level=False)
    sampled = areal_parameters(periodic_samples(g, 200), level=False)
    # Measured relative differences at 200 samples per cell: heights <= 1e-3, Ssk 9e-3;
    # Sdq/Sdr 3e-2 (cells straddling the ridges average two slopes; converges as 1/n).
    tolerances = {
        "Sa": 2e-3,
        "Sq": 2e-3,
        "Sku": 3e-3,
        "Ssk": 2e-2,
        "Sp": 1e-3,
        "Sv": 1e-3,
        "Sdq": 5e-2,
        "Sdr": 5e-2,
    }
    for key, tol in tolerances.items():
        assert sampled[key] == pytest.approx(exact[key], rel=tol), key


def test_mesh_sa_integrates_facets_that_cross_the_mean_plane():
    # The triangulated interpolant of a coarse random map, sampled at the centres of a fine
    # grid (midpoint rule): every coarse facet crosses or touches the mean plane somewhere.
    rng = np.random.default_rng(11)
    coarse = HeightMap(rng.normal(size=(4, 5)), 1.0, 1.0)
    n = 200  # fine samples per coarse cell
    t = (np.arange(n) + 0.5) / n
    fx, fy = np.meshgrid(t, t)
    lower = fx >= fy  # triangle (i,j),(i+1,j),(i+1,j+1) of from_heightmap
    z = coarse.heights
    z00, z10, z11, z01 = z[:-1, :-1], z[:-1, 1:], z[1:, 1:], z[1:, :-1]
    cells = np.where(
        lower,
        z00[..., None, None]
        + fx * (z10 - z00)[..., None, None]
        + fy * (z11 - z10)[..., None, None],
        z00[..., None, None]
        + fx * (z11 - z01)[..., None, None]
        + fy * (z01 - z00)[..., None, None],
    )
    fine = HeightMap(cells.transpose(0, 2, 1, 3).reshape(3 * n, 4 * n), 1.0 / n, 1.0 / n)
    exact = mesh_parameters(from_heightmap(coarse), level=False)
    sampled = areal_parameters(fine, level=False)
    for key in ("Sa", "Sq", "Ssk", "Sku"):
        assert sampled[key] == pytest.approx(exact[key], rel=1e-4), key


def test_mesh_and_map_share_sdq_and_extremes():
    hm = HeightMap(gaussian_field(40, 50, 4, 2, 1) * 1e-3, 1e-3, 2e-3)
    from_map = areal_parameters(hm, level=False)
    from_mesh = mesh_parameters(from_heightmap(hm), level=False)
    # Sdq of the map is defined as the exact Sdq of its triangulation.
    assert from_mesh["Sdq"] == pytest.approx(from_map["Sdq"], rel=1e-12)
    # Extremes: same points, different mean (point average vs area integral).
    assert from_mesh["Sz"] == pytest.approx(from_map["Sz"], rel=1e-12)


def test_levelling_removes_a_tilt_on_maps_and_meshes():
    z = gaussian_field(48, 64, 5, 3, 2) * 1e-3
    px, py = 1e-3, 1.5e-3
    x, y = px * np.arange(64), py * np.arange(48)
    tilted = z + 0.2 * x[None, :] - 0.1 * y[:, None] + 0.5
    flat_map, tilted_map = HeightMap(z, px, py), HeightMap(tilted, px, py)
    a, b = areal_parameters(flat_map), areal_parameters(tilted_map)
    for key in a:
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-15), key
    a, b = mesh_parameters(from_heightmap(flat_map)), mesh_parameters(from_heightmap(tilted_map))
    for key in a:
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-15), key
    assert np.nanmax(np.abs(level(tilted_map).heights - level(flat_map).heights)) < 1e-12


def test_mesh_levelled_tilted_plane_is_flat():
    x = np.arange(6) * 0.1
    hm = HeightMap(np.tile(0.3 * x, (4, 1)), 0.1, 0.1)
    got = mesh_parameters(from_heightmap(hm))
    for key in ("Sa", "Sq", "Sz", "Sdq", "Sdr"):
        assert got[key] == pytest.approx(0.0, abs=1e-12), key
    assert math.isnan(got["Ssk"])
    assert math.isnan(got["Sku"])


def test_mesh_parameters_refuse_overhangs_and_missing_top():
    mesh = from_heightmap(HeightMap(np.zeros((3, 3)), 1.0, 1.0))
    with pytest.raises(ConfigError, match="mesh: 8 top faces overhang"):
        mesh_parameters(TriangleMesh(mesh.vertices, mesh.faces[:, ::-1]))
    with pytest.raises(ConfigError, match="mesh: has no top faces"):
        mesh_parameters(TriangleMesh(mesh.vertices, mesh.faces, top=np.zeros(8, bool)))


# --- height-map statistics ------------------------------------------------------------------


def test_gaussian_surface_has_iso_kurtosis_three():
    # White Gaussian noise, 256 x 256 points: sd of Ssk ~ sqrt(6/n) = 0.01, of Sku ~ sqrt(24/n) =
    # 0.02.
    z = np.random.default_rng(4).normal(size=(256, 256))
    got = areal_parameters(HeightMap(z, 1.0, 1.0))
    assert got["Sku"] == pytest.approx(3.0, abs=0.08)
    assert got["Ssk"] == pytest.approx(0.0, abs=0.05)
    assert got["Sq"] == pytest.approx(1.0, abs=0.01)
    assert got["Sa"] == pytest.approx(math.sqrt(2 / math.pi), abs=0.01)


def test_sal_and_str_of_a_gaussian_correlated_surface():
    # ACF exp(-(x/8)² - (y/3)²): it drops to s = 0.2 at r = l sqrt(ln 5), so Sal = 3 sqrt(ln 5)
    # pixels and Str = 3/8. Over 8 seeds the estimates scatter by 2-3 % (sd); tolerance 8 %.
    hm = HeightMap(gaussian_field(256, 256, 8, 3, 0) * 1e-3, 2e-3, 2e-3)
    got = areal_parameters(hm)
    assert got["Sal"] == pytest.approx(3 * math.sqrt(math.log(5)) * 2e-3, rel=0.08)
    assert got["Str"] == pytest.approx(3 / 8, rel=0.08)


def test_spatial_parameters_use_physical_lags_for_rectangular_pixels():
    # Isotropic in pixels (l = 5) but pitch_x = 2 pitch_y: physically 10 x 5, so Str = 1/2 and
    # Sal = 5 sqrt(ln 5) (y pitch 1). Seeds 0-3 scatter by ~3 %; tolerance 8 %.
    got = areal_parameters(HeightMap(gaussian_field(256, 256, 5, 5, 1), 2.0, 1.0))
    assert got["Sal"] == pytest.approx(5 * math.sqrt(math.log(5)), rel=0.08)
    assert got["Str"] == pytest.approx(0.5, rel=0.08)


def test_str_is_nan_for_grooves_and_acf_is_normalised():
    x = np.arange(120)
    hm = HeightMap(np.tile(np.sin(2 * np.pi * x / 17.0), (90, 1)), 1.0, 1.0)
    got = areal_parameters(hm)
    assert math.isnan(got["Str"])  # no decay along the grooves
    assert 0 < got["Sal"] < 17 / 4 + 1  # decays across them within a quarter period (+ slack)
    acf = autocorrelation(hm)
    assert acf.shape == (2 * 45 + 1, 2 * 60 + 1)
    assert acf[45, 60] == 1.0
    np.testing.assert_allclose(acf, acf[::-1, ::-1], atol=1e-12)  # point-symmetric


def test_missing_points_are_left_out():
    z = gaussian_field(64, 64, 3, 3, 6)
    full = areal_parameters(HeightMap(z, 1.0, 1.0))
    padded = np.hstack([z, np.full((64, 3), np.nan)])  # a missing strip at the right
    got = areal_parameters(HeightMap(padded, 1.0, 1.0))
    for key in ("Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku", "Sdq", "Sdr", "Sal"):
        assert got[key] == pytest.approx(full[key], rel=1e-9), key


def test_flat_map_and_bad_threshold():
    got = areal_parameters(HeightMap(np.ones((8, 8)), 1.0, 1.0))
    assert got["Sq"] == 0.0
    assert got["Sdr"] == 0.0
    assert all(math.isnan(got[k]) for k in ("Ssk", "Sku", "Sal", "Str"))
    with pytest.raises(
        ConfigError, match=r"acf_threshold: must lie strictly between 0 and 1, got 1\.5"
    ):
        areal_parameters(HeightMap(np.ones((8, 8)), 1.0, 1.0), acf_threshold=1.5)


# --- independent reference: surfalize ---------------------------------------------------------


def _surfalize_reference(z: np.ndarray, pitch: float) -> dict[str, float]:
    surfalize = pytest.importorskip("surfalize")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        surface = surfalize.Surface(z, pitch, pitch).level()  # least-squares plane, like ours
        return {
            k: float(getattr(surface, k)())
            for k in ("Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku", "Sdq", "Sdr", "Sal", "Str")
        }


@pytest.mark.parametrize(
    ("shape", "lengths", "seed"),
    [((256, 256), (16, 6), 2), ((200, 300), (10, 25), 3), ((128, 128), (4, 4), 4)],
)
def test_against_surfalize_on_random_surfaces(shape, lengths, seed):
    z = gaussian_field(*shape, *lengths, seed) * 1e-3 + 1e-6 * np.arange(shape[1])[None, :]
    ref = _surfalize_reference(z, 1e-3)
    ours = areal_parameters(HeightMap(z, 1e-3, 1e-3))
    for key in ("Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku"):
        assert ours[key] == pytest.approx(ref[key], rel=1e-6), key
    # Same ISO D.15 cell area: agreement to rounding.
    assert ours["Sdr"] == pytest.approx(ref["Sdr"], rel=1e-9)
    # surfalize weights border differences fully, we half (cell average): measured <= 7e-4.
    assert ours["Sdq"] == pytest.approx(ref["Sdq"], rel=5e-3)
    # Different ray sets and interpolation of the same unbiased ACF: measured <= 0.4 %.
    assert ours["Sal"] == pytest.approx(ref["Sal"], rel=0.02)
    assert ours["Str"] == pytest.approx(ref["Str"], rel=0.02)


def test_against_surfalize_on_a_spike_grid():
    g = SpikeGrid(
        nx=6, ny=4, width_x=0.01, width_y=0.01, mean_height=0.005, height_sigma=0.001, seed=3
    )
    hm = g.to_heightmap(0.0005)
    ref = _surfalize_reference(hm.heights, 0.0005)
    ours = areal_parameters(hm)
    for key in ("Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku"):
        assert ours[key] == pytest.approx(ref[key], rel=1e-6), key
    assert ours["Sdr"] == pytest.approx(ref["Sdr"], rel=1e-9)
    assert ours["Sdq"] == pytest.approx(ref["Sdq"], rel=2e-2)  # 81 rows: border weight ~ 1/81
    assert ours["Sal"] == pytest.approx(ref["Sal"], rel=0.02)
    assert ours["Str"] == pytest.approx(ref["Str"], rel=0.02)


def test_unlevelled_heights_match_surfalize_without_levelling():
    surfalize = pytest.importorskip("surfalize")
    z = gaussian_field(64, 80, 4, 4, 8) + 0.01 * np.arange(80)[None, :]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = surfalize.Surface(z, 1.0, 1.0).height_parameters()
    ours = areal_parameters(HeightMap(z, 1.0, 1.0), level=False)
    for key in ("Sa", "Sq", "Sp", "Sv", "Sz", "Ssk", "Sku"):
        assert ours[key] == pytest.approx(ref[key], rel=1e-6), key


# --- periodic maps: one period --------------------------------------------------------------
def test_closed_periodic_map_is_measured_over_one_period():
    """A closed periodic tile gives the statistics of its period, not of the duplicated edge."""
    from score4.surface.processing import close_periodic, one_period
    from score4.surface.random import gaussian_random_surface

    period = gaussian_random_surface(
        24, 20, 1e-3, sq=1e-3, corr_length_x=3e-3, seed=5, periodic=True
    )
    closed = close_periodic(period)
    assert closed.shape == (21, 25)
    assert one_period(closed).shape == (20, 24)
    got, want = areal_parameters(closed), areal_parameters(period)
    for symbol, value in want.items():
        assert got[symbol] == pytest.approx(value, rel=1e-12, nan_ok=True), symbol
    # Without the reduction the duplicated edge changes the values (the test can fail):
    # the edge points count twice and weigh in the levelling plane.
    raw = areal_parameters(HeightMap(closed.heights, closed.pitch_x, closed.pitch_y))
    assert abs(raw["Sq"] / want["Sq"] - 1) > 1e-4
    # A map that is not a closed tile is left as it is.
    assert one_period(period) is period
