"""Height-map processing: levelling, cropping, resampling, filling missing points, periodic
closing."""

from __future__ import annotations

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.surface.heightmap import HeightMap
from score4.surface.processing import (
    close_periodic,
    crop,
    crop_samples,
    fill_missing,
    level_plane,
    plane_fit,
    resample,
)


def _map(f, nx=21, ny=11, px=0.5, py=0.25, origin=(1.0, -2.0)) -> HeightMap:
    x = origin[0] + px * np.arange(nx)
    y = origin[1] + py * np.arange(ny)
    yy, xx = np.meshgrid(y, x, indexing="ij")
    return HeightMap(f(xx, yy), px, py, origin=origin)


# ----------------------------------------------------------------------------- levelling
def test_level_plane_recovers_and_removes_the_plane():
    noise = np.random.default_rng(0).normal(scale=1e-3, size=(11, 21))
    hm = _map(lambda x, y: 0.3 + 0.02 * x - 0.05 * y + noise)
    _a, b, c = plane_fit(hm)
    assert (b, c) == pytest.approx((0.02, -0.05), abs=2e-4)  # noise 1e-3 over a 10 x 2.5 mm map
    flat = level_plane(hm)
    assert abs(flat.heights.mean()) < 1e-12
    _, b2, c2 = plane_fit(flat)
    assert abs(b2) < 1e-12
    assert abs(c2) < 1e-12
    assert flat.metadata["processing"][0].startswith("level_plane")


def test_level_plane_ignores_and_keeps_missing_points():
    z = _map(lambda x, y: 2.0 * x + y).heights
    z[3, 4] = np.nan
    flat = level_plane(HeightMap(z, 0.5, 0.25, origin=(1.0, -2.0)))
    assert np.isnan(flat.heights[3, 4])
    assert np.nanmax(np.abs(flat.heights)) < 1e-10


# ----------------------------------------------------------------------------- cropping
def test_crop_in_mm_and_in_samples():
    hm = _map(lambda x, y: x + 10 * y)
    part = crop(hm, x=(2.0, 4.0), y=("-1.5 mm", "-1000 um"))
    assert part.shape == (3, 5)  # y -1.5, -1.25, -1.0 ; x 2.0 ... 4.0
    assert part.origin == pytest.approx((2.0, -1.5))
    assert part.heights[0, 0] == pytest.approx(2.0 + 10 * -1.5)
    same = crop_samples(hm, columns=(2, 7), rows=(2, 5))
    np.testing.assert_array_equal(same.heights, part.heights)
    assert same.origin == part.origin
    assert crop_samples(hm, (None, None), (-3, None)).shape == (3, 21)


def test_crop_errors():
    hm = _map(lambda x, y: x)
    with pytest.raises(
        ConfigError, match=r"keeps 1 sample\(s\) of the map along x.*rule: at least 2"
    ):
        crop(hm, x=(2.0, 2.2), y=(-2.0, 0.0))
    with pytest.raises(ConfigError, match="at least 2 x 2"):
        crop_samples(hm, (5, 5), (0, 3))
    z = np.full((6, 6), np.nan)
    z[0, 0] = 1.0
    with pytest.raises(ConfigError, match="NaN"):
        crop_samples(HeightMap(z, 1.0, 1.0), (2, 6), (2, 6))  # only missing points left


# ----------------------------------------------------------------------------- resampling
def test_linear_resampling_is_exact_on_a_plane():
    hm = _map(lambda x, y: 3 * x - 2 * y)
    fine = resample(hm, "125 um", 0.125)
    assert fine.shape == (21, 81)  # a 10 x 2.5 mm map: 80 and 20 steps of 0.125 mm
    yy, xx = np.meshgrid(fine.y, fine.x, indexing="ij")
    np.testing.assert_allclose(fine.heights, 3 * xx - 2 * yy, atol=1e-12)


def test_cubic_resampling_of_a_smooth_surface():
    f = lambda x, y: np.sin(x) * np.cos(2 * y)  # noqa: E731
    hm = _map(f, nx=41, ny=41, px=0.1, py=0.1, origin=(0.0, 0.0))
    # bilinear error <= h^2/8 (|f_xx| + |f_yy|) = 0.01/8 * 5 = 6.3e-3; cubic error ~ h^4
    for method, tol in (("linear", 7e-3), ("cubic", 2e-4)):
        out = resample(hm, 0.03, method=method)
        yy, xx = np.meshgrid(out.y, out.x, indexing="ij")
        assert np.max(np.abs(out.heights - f(xx, yy))) < tol
        assert out.x[-1] <= hm.x[-1] + 1e-12


def test_resampling_errors_and_nan():
    z = _map(lambda x, y: x).heights
    z[5, 5] = np.nan
    hm = HeightMap(z, 0.5, 0.25, origin=(1.0, -2.0))
    with pytest.raises(ConfigError, match="cubic"):
        resample(hm, 0.1, method="cubic")
    with pytest.raises(ConfigError, match="method"):
        resample(hm, 0.1, method="sinc")
    with pytest.raises(ConfigError, match="pitch"):
        resample(hm, 100.0)
    lin = resample(hm, 0.25, 0.25)
    assert np.isnan(lin.heights).sum() > 0  # NaN spreads to neighbouring new samples only
    assert np.isnan(lin.heights).mean() < 0.05


# ----------------------------------------------------------------------------- filling
def test_laplace_fill_reproduces_a_harmonic_surface():
    # x^2 - y^2 has a zero discrete Laplacian on a square grid: the fill must be exact
    hm = _map(lambda x, y: x**2 - y**2, nx=30, ny=30, px=0.1, py=0.1, origin=(0.0, 0.0))
    z = hm.heights.copy()
    z[10:16, 12:20] = np.nan
    filled = fill_missing(HeightMap(z, 0.1, 0.1), max_fraction=0.1)
    np.testing.assert_allclose(filled.heights, hm.heights, atol=1e-9)


def test_fill_at_the_edge_stays_within_the_measured_range():
    z = np.random.default_rng(0).normal(size=(20, 20))
    z[:3, :5] = np.nan  # a corner gap: mirror boundary at the map edge
    filled = fill_missing(HeightMap(z, 1.0, 1.0))
    assert not filled.has_missing
    assert np.nanmin(z) <= filled.heights[:3, :5].min()
    assert filled.heights[:3, :5].max() <= np.nanmax(z)


def test_too_many_missing_points_are_refused():
    z = np.random.default_rng(0).normal(size=(10, 10))
    z[:5] = np.nan
    with pytest.raises(ConfigError, match=r"50\.0% of the points are missing.*max_fraction"):
        fill_missing(HeightMap(z, 1.0, 1.0), max_fraction=0.3)
    assert not fill_missing(HeightMap(z, 1.0, 1.0), max_fraction=0.6).has_missing
    with pytest.raises(ConfigError, match="max_fraction"):
        fill_missing(HeightMap(z, 1.0, 1.0), max_fraction=1.5)


def test_nan_only_map_is_an_error():
    with pytest.raises(ConfigError, match="NaN"):
        HeightMap(np.full((5, 5), np.nan), 1.0, 1.0)


# ----------------------------------------------------------------------------- periodic closing
def test_close_periodic_appends_the_duplicate_edge():
    z = np.arange(12.0).reshape(3, 4)
    closed = close_periodic(HeightMap(z, 1.0, 2.0))
    assert closed.shape == (4, 5)
    np.testing.assert_array_equal(closed.heights[:, -1], closed.heights[:, 0])
    np.testing.assert_array_equal(closed.heights[-1], closed.heights[0])
    assert closed.size_x == pytest.approx(4.0)  # one full period
