"""SpikeGrid: validation, heights, exact top mesh, frustums and height-map sampling."""

from __future__ import annotations

import math

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.surface.spikes import (
    MAX_TRUNCATED_FRACTION,
    MIN_LAYER_HEIGHT,
    PEAK_STEEPNESS,
    SpikeGrid,
)
from score4.surface.triangle_mesh import closed_body, degenerate_faces, is_watertight, signed_volume

SHAPES = [("pyramid", 1), ("bump", 1), ("bump", 5), ("peak", 4)]


def _grid(**kw) -> SpikeGrid:
    base = dict(
        nx=5, ny=3, width_x=0.004, width_y=0.0025, mean_height=0.003, height_sigma=0.0008, seed=7
    )
    return SpikeGrid(**{**base, **kw})


# --- validation ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        (dict(nx=0), "nx: must be an integer >= 1, got 0"),
        (dict(ny=-2), "ny: must be an integer >= 1"),
        (dict(nx=2.5), "nx: must be an integer"),
        (dict(width_x=0.0), "width_x: must be a positive length, got 0.0"),
        (dict(width_y=-1e-3), "width_y: must be a positive length"),
        (dict(mean_height=-0.001), "mean_height: must be a positive length"),
        (dict(height_sigma=-1e-4), "height_sigma: must be a length >= 0"),
        (dict(shape="cone"), "shape: must be one of pyramid, bump, peak"),
        (dict(shape="bump", n_layers=0), "n_layers: must be an integer >= 1, got 0"),
        (dict(n_layers=3), "n_layers: a pyramid is a single layer"),
        (dict(min_height=0.004), "min_height: must be below mean_height"),
        (dict(min_height=1e-9), "min_height: .* thinner than"),
        (dict(seed=-1), "seed: must be an integer >= 0"),
        (dict(width_x="5 parsec"), "width_x: unknown length unit"),
    ],
)
def test_bad_input_raises_config_error(kw, match):
    with pytest.raises(ConfigError, match=match):
        _grid(**kw)


def test_spread_that_truncates_too_much_is_refused():
    # P(h < 1 % of the mean) = Phi(-0.99 / 3) = 0.37 > MAX_TRUNCATED_FRACTION.
    with pytest.raises(ConfigError, match=r"height_sigma: .* below min_height.* at most 25 %"):
        _grid(mean_height=1.0, height_sigma=3.0)
    # Just under the limit works: Phi(-0.99 / 1.4) = 0.24.
    assert _grid(mean_height=1.0, height_sigma=1.4).heights.min() >= 0.01


def test_lengths_accept_unit_strings():
    g = SpikeGrid(
        nx=2, ny=2, width_x="5 um", width_y="4 um", mean_height="3 um", height_sigma="0.5 um"
    )
    assert (g.width_x, g.width_y, g.mean_height, g.height_sigma) == pytest.approx(
        (5e-3, 4e-3, 3e-3, 5e-4)
    )


# --- heights ------------------------------------------------------------------------------


def test_equal_heights_without_spread():
    g = _grid(height_sigma=0.0)
    np.testing.assert_array_equal(g.heights, np.full((3, 5), 0.003))
    assert g.truncated_fraction == 0.0


def test_heights_are_seeded_and_shaped_ny_nx():
    a, b, c = _grid(seed=1), _grid(seed=1), _grid(seed=2)
    assert a.heights.shape == (3, 5)
    np.testing.assert_array_equal(a.heights, b.heights)
    assert not np.array_equal(a.heights, c.heights)
    # Draws follow default_rng(seed).normal in C order when nothing is truncated.
    np.testing.assert_array_equal(a.heights, np.random.default_rng(1).normal(0.003, 0.0008, (3, 5)))


def test_truncated_gaussian_statistics():
    # 200 x 200 spikes, mean 1, sigma 1, truncated at 0.01: expected fraction Phi(-0.99) = 0.161.
    g = SpikeGrid(
        nx=200, ny=200, width_x=1.0, width_y=1.0, mean_height=1.0, height_sigma=1.0, seed=3
    )
    alpha = (g.height_floor - 1.0) / 1.0
    p_low = 0.5 * math.erfc(-alpha / math.sqrt(2))
    assert g.heights.min() >= g.height_floor
    # Binomial sd of the fraction is sqrt(p(1-p)/n) = 0.0018; tolerance ~5 sd.
    assert g.truncated_fraction == pytest.approx(p_low, abs=0.01)
    # Mean of the truncated normal: mu + sigma phi(alpha) / (1 - Phi(alpha)); sd of the mean 0.004.
    phi = math.exp(-alpha * alpha / 2) / math.sqrt(2 * math.pi)
    assert g.heights.mean() == pytest.approx(1.0 + phi / (1 - p_low), abs=0.02)
    assert p_low < MAX_TRUNCATED_FRACTION


# --- top mesh -----------------------------------------------------------------------------


@pytest.mark.parametrize(("shape", "n_layers"), SHAPES)
def test_top_mesh_is_an_exact_clean_height_field(shape, n_layers):
    g = _grid(shape=shape, n_layers=n_layers)
    m = g.top_mesh()
    assert m.n_faces == g.n_spikes * (8 * (n_layers - 1) + 4)
    assert degenerate_faces(m).size == 0
    assert (m.normals[:, 2] > 0).all()  # outward = up, no vertical or overhanging facet
    assert m.projected_areas.sum() == pytest.approx(g.size_x * g.size_y, rel=1e-12)
    lo, hi = m.bounds
    np.testing.assert_allclose(lo, [-g.size_x / 2, -g.size_y / 2, 0.0], atol=1e-15)
    np.testing.assert_allclose(hi[:2], [g.size_x / 2, g.size_y / 2], atol=1e-15)
    assert hi[2] == g.heights.max()
    # Faces are grouped by spike and lie inside their spike's cell.
    centres = m.vertices[m.faces].mean(axis=1)
    i, j = m.facet % g.nx, m.facet // g.nx
    assert (np.abs(centres[:, 0] - g.x_centres[i]) < g.width_x / 2).all()
    assert (np.abs(centres[:, 1] - g.y_centres[j]) < g.width_y / 2).all()


def test_pyramid_apexes_at_cell_centres_non_square_cells():
    g = _grid(nx=4, ny=7, width_x=0.003, width_y=0.001)
    m = g.top_mesh()
    apex = m.vertices[-g.n_spikes :].reshape(g.ny, g.nx, 3)
    xs, ys = np.meshgrid(g.x_centres, g.y_centres)
    np.testing.assert_allclose(apex[..., 0], xs)
    np.testing.assert_allclose(apex[..., 1], ys)
    np.testing.assert_array_equal(apex[..., 2], g.heights)


@pytest.mark.parametrize(("shape", "n_layers"), SHAPES)
def test_closed_body_of_spikes(shape, n_layers):
    g = _grid(shape=shape, n_layers=n_layers)
    body = closed_body(g.top_mesh(), thickness=0.01)
    assert is_watertight(body)
    assert degenerate_faces(body).size == 0
    # The body volume is the slab under the base plus the spikes' frustums (the Geant4 solids).
    f = g.frustums()
    x1, x2, y1, y2 = f["width_x_bottom"], f["width_x_top"], f["width_y_bottom"], f["width_y_top"]
    frustum_volume = f["height"] * (
        x1 * y1 + (x1 * (y2 - y1) + y1 * (x2 - x1)) / 2 + (x2 - x1) * (y2 - y1) / 3
    )
    expected = g.size_x * g.size_y * 0.01 + frustum_volume.sum()
    assert signed_volume(body) == pytest.approx(expected, rel=1e-12)


# --- frustums -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("shape", "profile"),
    [("bump", lambda u: 1 - u**2), ("peak", lambda u: 1 / (1 + PEAK_STEEPNESS * u))],
)
def test_frustum_layers_follow_the_profile(shape, profile):
    n = 6
    g = _grid(shape=shape, n_layers=n)
    f = g.frustums().reshape(g.n_spikes, n)
    k = np.arange(n)
    np.testing.assert_allclose(f["width_x_bottom"][0], g.width_x * profile(k / n))
    np.testing.assert_allclose(f["width_y_bottom"][0], g.width_y * profile(k / n))
    np.testing.assert_allclose(f["width_x_top"][0, :-1], f["width_x_bottom"][0, 1:])
    assert f["width_x_top"][0, -1] == 0.0
    assert f["width_y_top"][0, -1] == 0.0
    # Layers stack without gaps from z = 0 to the spike height.
    bottom, top = f["z"] - f["height"] / 2, f["z"] + f["height"] / 2
    np.testing.assert_allclose(bottom[:, 0], 0.0, atol=1e-18)
    np.testing.assert_allclose(bottom[:, 1:], top[:, :-1])
    np.testing.assert_allclose(top[:, -1], g.heights.ravel())
    np.testing.assert_array_equal(f["spike"][:, 0], np.arange(g.n_spikes))
    np.testing.assert_array_equal(f["layer"][0], k)
    xs, ys = np.meshgrid(g.x_centres, g.y_centres)
    np.testing.assert_allclose(f["x"][:, 0], xs.ravel())
    np.testing.assert_allclose(f["y"][:, 0], ys.ravel())


def test_layers_respect_the_geant4_minimum_height():
    g = _grid(shape="peak", n_layers=10, mean_height=1e-4, height_sigma=5e-5, min_height=1e-6)
    assert (g.frustums()["height"] >= MIN_LAYER_HEIGHT).all()


# --- sampling -----------------------------------------------------------------------------


def test_height_at_pyramid_matches_formula():
    g = _grid(height_sigma=0.0, nx=2, ny=2, width_x=2.0, width_y=1.0, mean_height=1.0)
    # Spike (0, 0) is centred at (-1, -0.5); z = h (1 - max(|u|, |v|)) in relative cell coordinates.
    x = np.array([-1.0, -1.5, -1.0, -0.25, -2.0, 0.0])
    y = np.array([-0.5, -0.5, -0.75, -0.5, -1.0, 0.0])
    expected = 1.0 - np.maximum(np.abs(x + 1.0) / 1.0, np.abs(y + 0.5) / 0.5)
    np.testing.assert_allclose(g.height_at(x, y), expected, atol=1e-15)


@pytest.mark.parametrize(("shape", "n_layers"), SHAPES)
def test_height_at_reproduces_mesh_vertices(shape, n_layers):
    g = _grid(shape=shape, n_layers=n_layers)
    v = g.top_mesh().vertices
    np.testing.assert_allclose(g.height_at(v[:, 0], v[:, 1]), v[:, 2], rtol=1e-12, atol=1e-15)


def test_height_at_lies_on_the_facets():
    g = _grid(shape="bump", n_layers=3)
    m = g.top_mesh()
    rng = np.random.default_rng(0)
    w = rng.dirichlet([1, 1, 1], size=m.n_faces)  # random barycentric point on each facet
    p = np.einsum("fk,fkd->fd", w, m.vertices[m.faces])
    np.testing.assert_allclose(g.height_at(p[:, 0], p[:, 1]), p[:, 2], rtol=1e-10, atol=1e-15)


def test_to_heightmap_grid_and_values():
    g = _grid(nx=4, ny=2, width_x=0.004, width_y=0.002)
    hm = g.to_heightmap((0.0005, 0.00025))
    assert hm.shape == (17, 33)  # 0.004 / 0.00025 + 1 rows, 0.016 / 0.0005 + 1 columns
    assert hm.origin == pytest.approx((-0.008, -0.002))
    assert (hm.pitch_x, hm.pitch_y) == (0.0005, 0.00025)
    # A cell spans 8 samples each way: samples 4, 12, ... hit the apexes, 0, 8, 16 the borders.
    np.testing.assert_allclose(hm.heights[4::8, 4::8], g.heights, rtol=1e-12)
    np.testing.assert_allclose(
        hm.heights[::8, :], 0.0, atol=1e-15
    )  # cell borders y = -0.002, 0, 0.002
    with pytest.raises(ConfigError, match=r"pitch: .* fewer than 2 samples"):
        g.to_heightmap(0.1)
    with pytest.raises(ConfigError, match="pitch: must be a positive length"):
        g.to_heightmap(0.0)
