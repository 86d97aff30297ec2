"""Area-uniform sampling on triangle sets and tiled faces; discrete and tabulated laws.

Statistical tests use fixed seeds and 2e5 draws; a chi-square or KS test passes at p > 0.001.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, stats

from score4.errors import ConfigError
from score4.source.sampling import (
    DiscreteSampler,
    Histogram,
    PiecewiseLinear,
    SurfaceSampler,
    TiledSurfaceSampler,
    read_table,
    triangle_areas,
    triangle_normals,
)

from conftest import pyramid_triangles

N = 200_000
P_MIN = 1e-3


def pyramid_patch(nx: int, ny: int, pitch: float = 1.0, heights=None) -> np.ndarray:
    """Square pyramids on an nx x ny grid (unit height unless given), 4 triangles each."""
    return pyramid_triangles(nx, ny, pitch, 1.0 if heights is None else heights)


def flat_patch(px: float, py: float) -> np.ndarray:
    return np.array(
        [[[0, 0, 0], [px, 0, 0], [px, py, 0]], [[0, 0, 0], [px, py, 0], [0, py, 0]]], float
    )


def in_plane_and_inside(p: np.ndarray, tri: np.ndarray, tol: float = 1e-9) -> bool:
    """All points lie in the plane of their triangle and inside it."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    n = np.cross(e1, e2)
    off = np.einsum("ij,ij->i", p - tri[:, 0], n) / np.linalg.norm(n, axis=1)
    # barycentric from the normal equations of the 2 x 2 system
    d = p - tri[:, 0]
    g11, g12, g22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    r1, r2 = (d * e1).sum(1), (d * e2).sum(1)
    det = g11 * g22 - g12 * g12
    s, t = (g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det
    return bool(
        (np.abs(off) < tol).all()
        and (s > -tol).all()
        and (t > -tol).all()
        and (s + t < 1 + tol).all()
    )


# ---------------------------------------------------------------- discrete choice


@pytest.mark.parametrize(
    "weights",
    [
        np.random.default_rng(0).random(1000),
        np.r_[0.0, 0.0, 3.0, 0.0, 1.0, 0.0],  # zeros at both ends and inside
        np.r_[1.0, np.full(100_000, 1e-9)],  # one huge entry and many tiny ones
        np.r_[np.full(5000, 1e-12), 1.0, np.full(5000, 1e-12)],
        np.array([2.5]),
    ],
)
def test_discrete_sampler_equals_exact_inverse_cdf(weights):
    # same uniforms as the sampler: the guide table + bisection must equal a full searchsorted
    n = 50_000
    got = DiscreteSampler(weights).sample(np.random.default_rng(7), n)
    positive = np.flatnonzero(weights > 0)
    cum = np.concatenate([[0.0], np.cumsum(weights[positive])])
    r = np.random.default_rng(7).random(n)
    expected = positive[np.searchsorted(cum, r * cum[-1], side="right") - 1]
    np.testing.assert_array_equal(got, expected)
    assert (weights[got] > 0).all()


@pytest.mark.parametrize("weights", [[], [1.0, -1.0], [0.0, 0.0], [1.0, np.nan], [[1.0, 2.0]]])
def test_discrete_sampler_rejects_bad_weights(weights):
    with pytest.raises(ConfigError, match="weights"):
        DiscreteSampler(weights)


# ---------------------------------------------------------------- one triangle set


def test_points_lie_in_their_triangles_with_the_outward_normal():
    tri = pyramid_patch(3, 2, heights=np.arange(1, 7).reshape(3, 2))
    sampler = SurfaceSampler(tri)
    s = sampler.sample(np.random.default_rng(1), 5000)
    assert in_plane_and_inside(s.position, tri[s.facet])
    np.testing.assert_allclose(s.normal, triangle_normals(tri)[s.facet])
    np.testing.assert_allclose(np.linalg.norm(s.normal, axis=1), 1.0)
    assert (s.normal[:, 2] > 0).all()  # counter-clockwise seen from above: outward = up


def test_vertices_plus_faces_equals_triangle_array():
    tri = pyramid_patch(2, 2)
    vertices, faces = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
    a = SurfaceSampler(tri).sample(np.random.default_rng(3), 1000)
    b = SurfaceSampler(vertices=vertices, faces=faces.reshape(-1, 3)).sample(
        np.random.default_rng(3), 1000
    )
    np.testing.assert_allclose(a.position, b.position)
    np.testing.assert_array_equal(a.facet, b.facet)


def test_facet_ids_are_reported():
    tri = flat_patch(1, 1)
    s = SurfaceSampler(tri, facet_ids=[10, 20]).sample(np.random.default_rng(0), 100)
    assert set(np.unique(s.facet)) == {10, 20}


def test_counts_per_facet_follow_true_area():
    # pyramids of very different slopes plus lone triangles spanning four decades of area
    tri = pyramid_patch(3, 3, heights=[[0.05, 0.3, 1], [2, 5, 0.1], [0.5, 8, 0.01]])
    extra = np.array(
        [[[10, 0, 0], [10 + s, 0, 0], [10, s, s]] for s in (0.01, 0.1, 1.0, 3.0)], dtype=float
    )
    tri = np.concatenate([tri, extra])
    counts = np.bincount(
        SurfaceSampler(tri).sample(np.random.default_rng(11), N).facet, minlength=len(tri)
    )
    areas = triangle_areas(tri)
    expected = N * areas / areas.sum()
    big = expected >= 5  # chi-square needs >= 5 expected counts per cell; merge the rest
    obs = np.r_[counts[big], counts[~big].sum()]
    exp = np.r_[expected[big], expected[~big].sum()]
    assert stats.chisquare(obs, exp).pvalue > P_MIN


def test_points_are_uniform_inside_a_triangle():
    # midpoint subdivision gives four sub-triangles of equal area: equal expected counts
    tri = np.array([[[0, 0, 0], [3, 0, 0], [2.5, 0.4, 1]]], float)
    p = SurfaceSampler(tri).sample(np.random.default_rng(5), N).position
    a, b, c = tri[0]
    e1, e2 = b - a, c - a
    st = np.linalg.lstsq(np.stack([e1, e2], axis=1), (p - a).T, rcond=None)[0].T
    s, t = st[:, 0], st[:, 1]
    region = np.where(s > 0.5, 0, np.where(t > 0.5, 1, np.where(s + t < 0.5, 2, 3)))
    assert stats.chisquare(np.bincount(region, minlength=4)).pvalue > P_MIN


def test_zero_area_triangles_are_never_chosen():
    tri = np.concatenate([flat_patch(1, 1), [[[0, 0, 0], [1, 1, 0], [2, 2, 0]]]])
    s = SurfaceSampler(tri).sample(np.random.default_rng(0), 10_000)
    assert (s.facet < 2).all()


def test_all_degenerate_surface_is_an_error():
    with pytest.raises(ConfigError, match="zero area"):
        SurfaceSampler(np.array([[[0, 0, 0], [1, 1, 0], [2, 2, 0]]], float))


# ---------------------------------------------------------------- tiled faces


def tiled_face(rotation=None):
    variants = [
        flat_patch(2.0, 1.0),
        pyramid_patch(2, 1, heights=[[1.0], [3.0]]),
        pyramid_patch(2, 1, heights=[[0.2], [0.2]]),
    ]
    layout = np.random.default_rng(4).integers(0, 3, size=(5, 4))
    return TiledSurfaceSampler(
        variants, layout, pitch=(2.0, 1.0), origin=(10.0, -3.0, 7.0), rotation=rotation
    )


def test_tiled_cells_are_chosen_by_the_true_area_of_their_variant():
    face = tiled_face()
    s = face.sample(np.random.default_rng(9), N)
    areas = np.array([v.area for v in face.variants])[face.layout.ravel()]
    counts = np.bincount(s.patch, minlength=face.layout.size)
    assert stats.chisquare(counts, N * areas / areas.sum()).pvalue > P_MIN
    np.testing.assert_array_equal(s.variant, face.layout.ravel()[s.patch])
    assert face.area == pytest.approx(areas.sum())


def test_tiled_points_are_translated_into_their_cell():
    face = tiled_face()
    s = face.sample(np.random.default_rng(2), 20_000)
    i, j = np.divmod(s.patch, face.shape[1])
    local = s.position - face.origin - np.c_[i * 2.0, j * 1.0, np.zeros(len(i))]
    for k, v in enumerate(face.variants):
        rows = s.variant == k
        assert in_plane_and_inside(local[rows], v.triangles[s.facet[rows]])
        np.testing.assert_allclose(s.normal[rows], v.normals[s.facet[rows]])


def test_tiled_face_rotation_moves_points_and_normals():
    angle = 0.7
    rot = np.array(
        [[1, 0, 0], [0, np.cos(angle), -np.sin(angle)], [0, np.sin(angle), np.cos(angle)]]
    )
    a = tiled_face().sample(np.random.default_rng(8), 1000)
    b = tiled_face(rot).sample(np.random.default_rng(8), 1000)
    origin = np.array([10.0, -3.0, 7.0])
    np.testing.assert_allclose(b.position, origin + (a.position - origin) @ rot.T)
    np.testing.assert_allclose(b.normal, a.normal @ rot.T)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"layout": [[0, 3]]}, "layout"),
        ({"layout": [[0.5, 1]]}, "layout"),
        ({"pitch": (0.0, 1.0)}, "pitch"),
        ({"rotation": np.diag([1.0, 1.0, -1.0])}, "rotation"),
    ],
)
def test_tiled_face_rejects_bad_input(kwargs, match):
    args = {"variants": [flat_patch(1, 1)], "layout": [[0, 0]], "pitch": (1.0, 1.0)} | kwargs
    with pytest.raises(ConfigError, match=match):
        TiledSurfaceSampler(**args)


# ---------------------------------------------------------------- tabulated laws


def test_piecewise_linear_inverse_is_exact_on_uneven_spacing():
    law = PiecewiseLinear([0.0, 0.1, 0.15, 1.0, 3.0], [0.0, 5.0, 5.0, 1.0, 0.0])
    q = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(law.cdf(law.ppf(q)), q, atol=1e-12)
    # the CDF is the integral of the PDF (trapezoid with many points is exact to ~1e-7 here)
    x = np.linspace(0, 3, 300_001)
    np.testing.assert_allclose(integrate.trapezoid(law.pdf(x), x), 1.0, rtol=1e-6)


def test_piecewise_linear_truncated_sampling_stays_in_window_and_follows_the_pdf():
    law = PiecewiseLinear([0.0, 1.0, 4.0], [1.0, 3.0, 0.0])
    x = law.sample(np.random.default_rng(3), N, lo=0.5, hi=2.0)
    assert x.min() >= 0.5
    assert x.max() <= 2.0
    edges = np.linspace(0.5, 2.0, 31)
    p = np.diff(law.cdf(edges)) / (law.cdf(2.0) - law.cdf(0.5))
    assert stats.chisquare(np.histogram(x, edges)[0], N * p).pvalue > P_MIN


def test_histogram_law_sampling():
    law = Histogram([1.0, 2.0, 2.5, 5.0], [1.0, 4.0, 2.0])
    x = law.sample(np.random.default_rng(6), N)
    edges = np.array([1.0, 1.5, 2.0, 2.25, 2.5, 3.0, 5.0])
    assert stats.chisquare(np.histogram(x, edges)[0], N * np.diff(law.cdf(edges))).pvalue > P_MIN


def test_read_table_with_header_comments_and_commas(tmp_path):
    f = tmp_path / "t.txt"
    f.write_text("# depth profile\n# unit: nm\n\n0, 0\n1.5 2   # peak\n4\t0\n")
    x, w = read_table(f, "length")
    np.testing.assert_allclose(x, [0, 1.5e-6, 4e-6])
    np.testing.assert_allclose(w, [0, 2, 0])
    x, _ = read_table(f, "length", unit="nm")  # the same unit as the header is fine
    assert x[1] == pytest.approx(1.5e-6)


@pytest.mark.parametrize(
    ("text", "unit", "match"),
    [
        ("0 1\n1 2\n", None, "no unit"),
        ("# unit: nm\n0 1\n1 2\n", "um", "must agree"),
        ("# unit: parsec\n0 1\n1 2\n", None, "unknown length unit"),
        ("# unit: nm\n0 1\n1 two\n", None, "line 3: cannot read"),
        ("# unit: nm\n0 1\n1 2 3\n", None, "line 3: cannot read"),
        ("# unit: nm\n-1 1\n1 2\n", None, "line 2: negative x"),
        ("# unit: nm\n0 1\n1 -2\n", None, "line 3: negative weight"),
        ("# unit: nm\n0 1\n2 2\n1 1\n", None, "line 4: unsorted"),
        ("# unit: nm\n0 1\n\n0 2\n", None, "line 4: duplicate"),
        ("# unit: nm\n0 0\n1 0\n", None, "all weights are zero"),
        ("# unit: nm\n0 1\n", None, "at least 2 rows"),
        ("# unit: nm\n# unit: um\n0 1\n1 1\n", None, "line 2: second unit header"),
    ],
)
def test_read_table_errors_name_file_line_and_rule(tmp_path, text, unit, match):
    f = tmp_path / "bad.txt"
    f.write_text(text)
    with pytest.raises(ConfigError, match=match) as err:
        read_table(f, "length", unit=unit)
    assert str(f) in str(err.value)


def test_block_sampling_is_prefix_stable_and_independent_of_chunking():
    from score4.source.emitters import ParticleEmitter, make_primaries
    from score4.source.event_blocks import BLOCK_EVENTS, draw_events

    class Flat:  # a 1 mm square at z = 0 emitting isotropic 1 MeV alphas
        def primaries(self, rng, first_event, n_events):
            pos = np.column_stack([rng.random((n_events, 2)), np.zeros(n_events)])
            return make_primaries(ParticleEmitter("alpha", 1.0, "isotropic"), rng, pos)

    n = 2 * BLOCK_EVENTS + 500
    whole = draw_events(Flat(), 3, 0, n)
    assert whole.n_events == n
    shorter = draw_events(Flat(), 3, 0, 1200)
    assert np.array_equal(shorter.position, whole.position[:1200])
    # any cut, across block boundaries, gives the same events
    pieces = [draw_events(Flat(), 3, s, k) for s, k in ((0, 700), (700, 700), (1400, n - 1400))]
    joined = whole.concatenate(pieces)
    assert np.array_equal(joined.position, whole.position)
    assert np.array_equal(joined.direction, whole.direction)
    assert not np.array_equal(draw_events(Flat(), 4, 0, 1200).position, shorter.position)
