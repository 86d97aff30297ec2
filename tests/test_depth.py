"""Depth profiles, the 'normal' and 'distance' depth definitions, exact mesh distances.

Statistical tests use fixed seeds and 2e5 vertices; a chi-square test passes at p > 0.001.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, stats
from scipy.spatial import cKDTree

from score4.common.units import nm
from score4.errors import ConfigError
from score4.source.depth import (
    MeshDistance,
    OffsetSurface,
    VertexSampler,
    closest_points_on_triangles,
)
from score4.source.profiles import (
    ExponentialProfile,
    MultiExponentialProfile,
    TableProfile,
    TruncatedGaussianProfile,
    UniformProfile,
    ZeroDepth,
)
from score4.source.sampling import SurfaceSampler, TiledSurfaceSampler

from conftest import pyramid_triangles

N = 200_000
P_MIN = 1e-3


# ---------------------------------------------------------------- geometry helpers


def flat_face(size: float = 10.0) -> np.ndarray:
    a, b, c, d = [0, 0, 0], [size, 0, 0], [size, size, 0], [0, size, 0]
    return np.array([[a, b, c], [a, c, d]], float)


def pyramids(nx: int, ny: int, heights, pitch: float = 1.0) -> np.ndarray:
    return pyramid_triangles(nx, ny, pitch, heights)


def v_groove(slope: float, half_width: float, length: float, ridge: bool = False) -> np.ndarray:
    """z = +-slope |x| for |x| <= half_width, 0 <= y <= length; material below; normals up."""
    z = (-1 if ridge else 1) * slope * half_width
    o, o2 = [0, 0, 0], [0, length, 0]
    r1, r2 = [half_width, 0, z], [half_width, length, z]
    l1, l2 = [-half_width, 0, z], [-half_width, length, z]
    return np.array([[o, r1, r2], [o, r2, o2], [l1, o, o2], [l1, o2, l2]], float)


def pit(slope: float, half_width: float) -> np.ndarray:
    """Inverted square pyramid z = slope max(|x|, |y|): one valley vertex, four valley edges."""
    w = half_width
    rim = [[w, -w, slope * w], [w, w, slope * w], [-w, w, slope * w], [-w, -w, slope * w]]
    return np.array([[[0, 0, 0], rim[k], rim[(k + 1) % 4]] for k in range(4)], float)


def chi2_pvalue(x: np.ndarray, edges: np.ndarray, cdf) -> float:
    """Chi-square p-value of samples against a CDF, with under/overflow cells."""
    counts = np.histogram(x, np.r_[-np.inf, edges, np.inf])[0]
    cum = np.r_[0.0, cdf(edges), 1.0]
    expected = len(x) * np.diff(cum)
    keep = expected > 0
    assert counts[~keep].sum() == 0, "samples where the law has no probability"
    return stats.chisquare(counts[keep], expected[keep]).pvalue


# ---------------------------------------------------------------- profiles


TABLE = (
    "# Po-210 like table, uneven spacing\n# unit: nm\n0 0\n2 10\n3 30\n10 25\n25 5\n60 1\n120 0\n"
)


def make_profile(kind: str, tmp_path):
    if kind == "table_uneven":
        f = tmp_path / "depth.txt"
        f.write_text(TABLE)
        return TableProfile.from_file(f)
    return {
        "exponential": lambda: ExponentialProfile(20 * nm),
        "two_exponentials": lambda: MultiExponentialProfile([0.7, 0.3], [5 * nm, 50 * nm]),
        "uniform": lambda: UniformProfile(10 * nm, 110 * nm),
        "gauss_cut_at_zero": lambda: TruncatedGaussianProfile(30 * nm, 20 * nm),
        "gauss_upper_tail": lambda: TruncatedGaussianProfile(
            30 * nm, 20 * nm, lower=80 * nm, upper=200 * nm
        ),
    }[kind]()


KINDS = [
    "table_uneven",
    "exponential",
    "two_exponentials",
    "uniform",
    "gauss_cut_at_zero",
    "gauss_upper_tail",
]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("window", [None, (12 * nm, 90 * nm)])
def test_depth_histogram_on_a_flat_face_matches_the_profile(kind, window, tmp_path):
    profile = make_profile(kind, tmp_path)
    lo, hi = window or (0.0, np.inf)
    if window and profile.mass(lo, hi) == 0:
        pytest.skip("window outside this profile")
    sampler = VertexSampler(SurfaceSampler(flat_face()), profile, min_depth=lo, max_depth=hi)
    v = sampler.sample(np.random.default_rng(21), N)
    depth = -v.position[:, 2]
    np.testing.assert_allclose(depth, v.depth, atol=1e-15)
    assert depth.min() >= lo
    assert depth.max() <= hi
    edges = np.linspace(max(lo, 0.0), min(hi, 250 * nm), 41)
    mass = profile.mass(lo, hi)
    assert (
        chi2_pvalue(
            depth, edges, lambda d: (profile.cdf(np.clip(d, lo, hi)) - profile.cdf(lo)) / mass
        )
        > P_MIN
    )


@pytest.mark.parametrize("kind", KINDS)
def test_pdf_is_normalised_and_integrates_to_the_cdf(kind, tmp_path):
    profile = make_profile(kind, tmp_path)
    breaks = [2 * nm, 3 * nm, 10 * nm, 25 * nm, 60 * nm, 80 * nm, 120 * nm]
    for x in (7 * nm, 33 * nm, 150 * nm):
        got = integrate.quad(profile.pdf, 0, x, points=[b for b in breaks if b < x], limit=200)[0]
        assert got == pytest.approx(float(profile.cdf(x)), abs=1e-9)
    assert integrate.quad(profile.pdf, 0, 5000 * nm, points=breaks, limit=200)[0] == pytest.approx(
        1.0, abs=1e-8
    )


def test_truncated_profile_pdf_is_renormalised(tmp_path):
    profile = make_profile("table_uneven", tmp_path).truncated(5 * nm, 40 * nm)
    assert integrate.quad(profile.pdf, 0, 200 * nm, points=[5 * nm, 10 * nm, 25 * nm, 40 * nm])[
        0
    ] == pytest.approx(1.0)


def test_zero_depth_puts_every_vertex_on_the_surface():
    tri = pyramids(2, 2, [[1.0, 0.5], [2.0, 0.1]])
    for definition in ("normal", "distance"):
        v = VertexSampler(SurfaceSampler(tri), ZeroDepth(), definition=definition).sample(
            np.random.default_rng(0), 5000
        )
        assert (v.depth == 0).all()
        np.testing.assert_allclose(MeshDistance(tri).distance(v.position)[0], 0.0, atol=1e-12)
    with pytest.raises(ConfigError, match="min_depth"):
        ZeroDepth().truncated(1 * nm)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("# unit: nm\n-1 1\n5 1\n", "line 2: negative depth"),
        ("# unit: nm\n0 1\n5 -1\n", "line 3: negative weight"),
        ("# unit: nm\n0 0\n5 0\n", "all weights are zero"),
        ("# unit: nm\n0 1\n5 1\n3 1\n", "line 4: unsorted depth"),
        ("# unit: nm\n0 1\n5 1\n5 2\n", "line 4: duplicate depth"),
        ("0 1\n5 1\n", "no unit"),
        ("# unit: nm\n0 1\n5 lots\n", "line 3: cannot read"),
    ],
)
def test_bad_depth_tables_name_file_line_and_rule(tmp_path, text, match):
    f = tmp_path / "profile.txt"
    f.write_text(text)
    with pytest.raises(ConfigError, match=match) as err:
        TableProfile.from_file(f)
    assert str(f) in str(err.value)


def test_unit_argument_replaces_a_missing_header(tmp_path):
    f = tmp_path / "profile.txt"
    f.write_text("0 1\n5 1\n")
    assert TableProfile.from_file(f, unit="um").depths[-1] == pytest.approx(5e-3)


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: ExponentialProfile(-1 * nm), "mean"),
        (lambda: ExponentialProfile(0.0), "mean"),
        (lambda: MultiExponentialProfile([1, 1], [5 * nm, -5 * nm]), r"means\[1\]"),
        (lambda: MultiExponentialProfile([1, -1], [5 * nm, 5 * nm]), "weights"),
        (lambda: TruncatedGaussianProfile(10 * nm, -1 * nm), "sigma"),
        (lambda: TruncatedGaussianProfile(-10 * nm, 1 * nm), "mean"),
        (lambda: UniformProfile(20 * nm, 10 * nm), "min / max"),
        (
            lambda: ExponentialProfile(1 * nm).truncated(30 * nm, 10 * nm),
            "min_depth / max_depth: .* > ",
        ),
        (lambda: UniformProfile(0, 10 * nm).truncated(20 * nm, 30 * nm), "no probability"),
        (
            lambda: VertexSampler(
                SurfaceSampler(flat_face()),
                ExponentialProfile(1 * nm),
                min_depth=2.0,
                max_depth=1.0,
            ),
            "min",
        ),
        (
            lambda: VertexSampler(
                SurfaceSampler(flat_face()), ExponentialProfile(1 * nm), definition="along"
            ),
            "definition",
        ),
    ],
)
def test_bad_profile_parameters(build, match):
    with pytest.raises(ConfigError, match=match):
        build()


# ---------------------------------------------------------------- exact distances


def closest_point_reference(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Independent closest point: plane projection if inside, else the best of three segments."""
    a, b, c = tri
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    q = p - np.dot(p - a, n) * n
    bary = np.linalg.lstsq(np.c_[b - a, c - a], q - a, rcond=None)[0]
    if bary.min() >= 0 and bary.sum() <= 1:
        return q
    best = None
    for s, e in ((a, b), (b, c), (c, a)):
        t = np.clip(np.dot(p - s, e - s) / np.dot(e - s, e - s), 0, 1)
        cand = s + t * (e - s)
        if best is None or np.linalg.norm(p - cand) < np.linalg.norm(p - best):
            best = cand
    return best


def test_closest_points_match_an_independent_reference():
    rng = np.random.default_rng(3)
    tri = rng.normal(size=(400, 3, 3))
    p = rng.normal(size=(400, 3)) * 2
    got = closest_points_on_triangles(p, tri[:, 0], tri[:, 1], tri[:, 2])
    ref = np.array([closest_point_reference(p[k], tri[k]) for k in range(len(p))])
    np.testing.assert_allclose(
        np.linalg.norm(p - got, axis=1), np.linalg.norm(p - ref, axis=1), rtol=1e-9, atol=1e-12
    )


@pytest.mark.parametrize("brute_max", [0, 64])
@pytest.mark.parametrize("period", [None, (3.0, 2.0)])
def test_mesh_distance_equals_brute_force(period, brute_max):
    rng = np.random.default_rng(5)
    centres = rng.random((150, 1, 3)) * [3.0, 2.0, 0.5]
    tri = centres + rng.normal(scale=[0.3, 0.3, 0.1], size=(150, 3, 3))
    tri = np.concatenate([tri, [[[0, 0, 0], [3, 0, 0.2], [0, 2, 0.1]]]])  # one large triangle
    points = rng.random((300, 3)) * [3.0, 2.0, 1.5] - [0, 0, 0.5]
    images = (
        [(0.0, 0.0)]
        if period is None
        else [(i * period[0], j * period[1]) for i in (-1, 0, 1) for j in (-1, 0, 1)]
    )
    brute = np.full(len(points), np.inf)
    for dx, dy in images:
        shifted = tri + np.array([dx, dy, 0])
        for k in range(len(shifted)):
            q = closest_points_on_triangles(
                points, *(np.broadcast_to(shifted[k, i], points.shape) for i in range(3))
            )
            brute = np.minimum(brute, np.linalg.norm(points - q, axis=1))
    md = MeshDistance(tri, period=period, chunk=64, brute_max=brute_max)  # small chunks: batching
    dist, index = md.distance(points)
    np.testing.assert_allclose(dist, brute, rtol=1e-12)
    if period is None:  # the reported triangle is a nearest one
        q = closest_points_on_triangles(points, tri[index, 0], tri[index, 1], tri[index, 2])
        np.testing.assert_allclose(np.linalg.norm(points - q, axis=1), dist, rtol=1e-12)
    radius = brute * rng.uniform(0.5, 1.5, len(points))
    np.testing.assert_array_equal(md.any_within(points, radius), brute < radius)


# ---------------------------------------------------------------- normal vs distance on V-grooves


def test_v_groove_valley_wedge_is_filled_only_by_distance():
    # Valley z = s|x| (module docstring): a 'distance' vertex at depth d lies in the wedge below
    # the valley line with probability theta d / (2 W r + theta d), theta = 2 atan(s); for d
    # uniform on [0, D] the mean is 1 - (a / D) ln(1 + D / a) with a = 2 W r / theta.
    # A 'normal' vertex never does: the inward normals diverge there.
    s, w, length, depth = 1.0, 1.0, 2.0, 1.0
    tri = v_groove(s, w, length)
    r, theta = np.sqrt(1 + s * s), 2 * np.arctan(s)
    a = 2 * w * r / theta
    expected = 1 - (a / depth) * np.log1p(depth / a)
    profile = UniformProfile(0.0, depth)
    for definition in ("distance", "normal"):
        v = VertexSampler(SurfaceSampler(tri), profile, definition=definition).sample(
            np.random.default_rng(31), N
        )
        x, z = v.position[:, 0], v.position[:, 2]
        wedge = np.abs(x) < s * -z
        if definition == "normal":
            assert wedge.sum() == 0
        else:
            k = wedge.sum()
            assert stats.chisquare([k, N - k], [N * expected, N * (1 - expected)]).pvalue > P_MIN
            np.testing.assert_allclose(np.hypot(x[wedge], z[wedge]), v.depth[wedge], rtol=1e-9)
        # no overlap in a valley: every vertex is at its drawn depth with both definitions
        np.testing.assert_allclose(
            MeshDistance(tri).distance(v.position)[0], v.depth, rtol=1e-9, atol=1e-12
        )


def test_v_groove_ridge_normal_vertices_come_too_close_distance_ones_do_not():
    # Ridge z = -s|x|: a 'normal' vertex drawn at |x_s| crosses the ridge plane, and is then
    # closer than d to the other facet, iff |x_s| < d s / r. With x_s uniform on [0, W] and d
    # uniform on [0, D] (D s / (W r) <= 1) that happens with probability D s / (2 W r).
    s, w, length, depth = 1.0, 1.0, 2.0, 1.0
    tri = v_groove(s, w, length, ridge=True)
    expected = depth * s / (2 * w * np.sqrt(1 + s * s))
    profile = UniformProfile(0.0, depth)
    for definition in ("normal", "distance"):
        v = VertexSampler(SurfaceSampler(tri), profile, definition=definition).sample(
            np.random.default_rng(32), N
        )
        true = MeshDistance(tri).distance(v.position)[0]
        too_close = true < v.depth * (1 - 1e-9) - 1e-12  # fp: coordinates ~1, depths down to ~1e-6
        if definition == "normal":
            k = too_close.sum()
            assert stats.chisquare([k, N - k], [N * expected, N * (1 - expected)]).pvalue > P_MIN
            assert (true <= v.depth + 1e-12).all()
        else:
            assert too_close.sum() == 0
            assert chi2_pvalue(true, np.linspace(0, depth, 21), profile.cdf) > P_MIN


def test_pit_level_sets_have_the_steiner_pieces():
    # Inverted pyramid z = s max(|x|, |y|): the level set at depth d has a facet part
    # A = 4 W^2 r, an edge part d sum(theta L) over the four valley diagonals and a vertex part
    # d^2 Omega, Omega = 4 asin(s^2 / (s^2 + 2)) the solid angle spanned by the inward normals.
    s, w, depth = 1.0, 1.0, 0.5
    tri = pit(s, w)
    area = 4 * w * w * np.sqrt(1 + s * s)
    edge = 4 * np.arccos(1 / (1 + s * s)) * w * np.sqrt(2 + s * s)
    omega = 4 * np.arcsin(s * s / (s * s + 2))

    def total(d):
        return area + edge * d + omega * d * d

    parts = [lambda d: area, lambda d: edge * d, lambda d: omega * d * d]
    expected = np.array(
        [integrate.quad(lambda d, f=f: f(d) / total(d), 0, depth)[0] / depth for f in parts]
    )
    v = VertexSampler(SurfaceSampler(tri), UniformProfile(0, depth), definition="distance").sample(
        np.random.default_rng(33), N
    )
    p, d = v.position, v.depth
    on_vertex = np.abs(np.linalg.norm(p, axis=1) - d) <= 1e-9 * d + 1e-12
    diag = np.array([[w, w, s * w], [-w, w, s * w], [-w, -w, s * w], [w, -w, s * w]])
    diag_dist = []
    for e in diag:  # distance to the segment from the bottom vertex to a rim corner
        t = np.clip(p @ e / (e @ e), 0, 1)
        diag_dist.append(np.linalg.norm(p - t[:, None] * e, axis=1))
    on_edge = ~on_vertex & (np.abs(np.min(diag_dist, axis=0) - d) <= 1e-9 * d + 1e-12)
    counts = [N - on_vertex.sum() - on_edge.sum(), on_edge.sum(), on_vertex.sum()]
    assert stats.chisquare(counts, N * expected).pvalue > P_MIN
    np.testing.assert_allclose(MeshDistance(tri).distance(p)[0], d, rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------- rough surfaces and constraints


ROUGH = pyramids(4, 3, [[0.5, 1.5, 0.2], [2.0, 0.8, 1.2], [0.3, 1.0, 2.5], [1.1, 0.6, 0.9]])


def test_distance_depth_histogram_matches_the_profile_on_pyramids(tmp_path):
    f = tmp_path / "depth.txt"
    f.write_text("# unit: um\n0 0\n20 10\n30 30\n100 25\n250 5\n400 0\n")
    profile = TableProfile.from_file(f)
    v = VertexSampler(SurfaceSampler(ROUGH), profile, definition="distance").sample(
        np.random.default_rng(41), N
    )
    true = MeshDistance(ROUGH).distance(v.position)[0]
    np.testing.assert_allclose(true, v.depth, rtol=1e-9, atol=1e-12)
    assert chi2_pvalue(true, np.linspace(0, 0.4, 41), profile.cdf) > P_MIN
    np.testing.assert_allclose(np.linalg.norm(v.normal, axis=1), 1.0)


def test_normal_depth_on_pyramids_overlaps_under_ridges():
    v = VertexSampler(SurfaceSampler(ROUGH), UniformProfile(0, 0.3)).sample(
        np.random.default_rng(42), 20_000
    )
    true = MeshDistance(ROUGH).distance(v.position)[0]
    assert (true <= v.depth + 1e-12).all()
    assert (true < 0.99 * v.depth).mean() > 0.01  # the paper's definition: some come closer


@pytest.mark.parametrize("definition", ["normal", "distance"])
def test_no_vertex_violates_the_depth_window_or_the_confinement(definition):
    lo, hi = 0.05, 0.3

    def inside(p):
        return (p[:, 0] < 2.5) & (p[:, 1] > 0.7)

    sampler = VertexSampler(
        SurfaceSampler(ROUGH),
        ExponentialProfile(0.1),
        definition=definition,
        min_depth=lo,
        max_depth=hi,
        inside=inside,
    )
    v = sampler.sample(np.random.default_rng(43), N)
    assert inside(v.position).all()
    assert v.depth.min() >= lo
    assert v.depth.max() <= hi
    if definition == "distance":
        true = MeshDistance(ROUGH).distance(v.position)[0]
        assert true.min() >= lo * (1 - 1e-9)
        assert true.max() <= hi + 1e-12
    else:  # the vertex moved back by its depth along the normal lies on its facet's plane
        corner = ROUGH[v.facet, 0]
        back = v.position + v.depth[:, None] * v.normal
        np.testing.assert_allclose(np.einsum("ij,ij->i", back - corner, v.normal), 0.0, atol=1e-12)


def test_unsatisfiable_confinement_raises_with_counts():
    sampler = VertexSampler(
        SurfaceSampler(ROUGH),
        ExponentialProfile(0.1),
        inside=lambda p: np.zeros(len(p), bool),
        max_rounds=3,
    )
    with pytest.raises(
        ConfigError, match=r"100 of 100 vertices .* 300 draws were outside the confinement"
    ):
        sampler.sample(np.random.default_rng(0), 100)


def test_bad_confinement_callable_is_reported():
    sampler = VertexSampler(
        SurfaceSampler(ROUGH), ExponentialProfile(0.1), inside=lambda p: np.ones(3)
    )
    with pytest.raises(ConfigError, match="inside"):
        sampler.sample(np.random.default_rng(0), 10)


def periodic_height_map(
    n: int, sq: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """A smooth random periodic height field on [0, 1]^2 (n x n cells, 2 triangles each)."""
    k2 = np.fft.fftfreq(n)[:, None] ** 2 + np.fft.fftfreq(n)[None, :] ** 2
    z = np.real(np.fft.ifft2(np.fft.fft2(rng.normal(size=(n, n))) * np.exp(-20 * k2)))
    z = np.pad(z * sq / z.std(), ((0, 1), (0, 1)), mode="wrap")
    i, j = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))

    def corner(a, b):
        return np.c_[a / n, b / n, z[a, b]]

    q00, q10, q11, q01 = corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)
    return np.concatenate([np.stack([q00, q10, q11], 1), np.stack([q00, q11, q01], 1)]), z


def test_distance_vertices_are_uniform_on_the_level_sets_of_a_rough_height_map():
    # Independent check of the whole construction (facet, edge and vertex pieces, trimming):
    # points uniform in the volume, kept when inside the material and in the thin shell
    # d0 <= dist <= d0 + eps, are uniform on the level sets too (up to the O(eps) change of
    # |L_t| across the shell). Two-sample KS tests on coordinates and on the distance to the
    # nearest mesh vertex (sensitive to the edge and vertex pieces), p > 0.001.
    rng = np.random.default_rng(7)
    n, d0, eps = 8, 0.06, 0.01
    tri, z = periodic_height_map(n, 0.12, rng)
    sampler = VertexSampler(
        SurfaceSampler(tri), UniformProfile(d0, d0 + eps), definition="distance", period=(1.0, 1.0)
    )
    assert sampler.offset_surfaces[0].n_vertex_cones > 5
    v = sampler.sample(rng, 20_000)
    ours = v.position
    ours[:, :2] %= 1.0
    md = MeshDistance(tri, period=(1.0, 1.0))
    m = 200_000
    q = np.c_[rng.random((m, 2)), z.min() - d0 - eps + rng.random(m) * (np.ptp(z) + eps)]
    q = q[md.any_within(q, d0 + eps) & ~md.any_within(q, d0)]
    u, w = q[:, 0] * n, q[:, 1] * n  # material = below the triangulated height
    a, b = np.floor(u).astype(int), np.floor(w).astype(int)
    fu, fw = u - a, w - b
    z00, z10, z11, z01 = z[a, b], z[a + 1, b], z[a + 1, b + 1], z[a, b + 1]
    h = np.where(
        fu >= fw,
        z00 + fu * (z10 - z00) + fw * (z11 - z10),
        z00 + fw * (z01 - z00) + fu * (z11 - z01),
    )
    reference = q[q[:, 2] < h]
    assert len(reference) > 3000
    vertices = tri.reshape(-1, 3)
    images = np.concatenate(
        [vertices + np.array([dx, dy, 0]) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
    )

    def to_vertex(p):
        return cKDTree(images).query(p)[0]

    for stat in (lambda p: p[:, 0], lambda p: p[:, 1], lambda p: p[:, 2], to_vertex):
        assert stats.ks_2samp(stat(ours[:5000]), stat(reference)).pvalue > P_MIN
    # share of points whose closest surface point is a mesh vertex (the vertex pieces)
    at_vertex = [
        int((np.abs(to_vertex(ours) - v.depth) <= 1e-9).sum()),
        int((np.abs(to_vertex(reference) - md.distance(reference)[0]) <= 1e-9).sum()),
    ]
    table = [at_vertex, [len(ours) - at_vertex[0], len(reference) - at_vertex[1]]]
    assert min(at_vertex) > 20
    assert stats.chi2_contingency(table).pvalue > P_MIN


# ---------------------------------------------------------------- periodic tiles and tiled faces


def tile_copies(tile: np.ndarray, n: int, pitch: float = 1.0) -> np.ndarray:
    """The tile repeated on an n x n grid centred on the original (n odd)."""
    k = n // 2
    return np.concatenate(
        [
            tile + np.array([i * pitch, j * pitch, 0])
            for i in range(-k, k + 1)
            for j in range(-k, k + 1)
        ]
    )


def test_periodic_tile_welds_its_border_edges():
    p, h = 1.0, 0.8
    tile = pyramids(1, 1, h, pitch=p)
    # base edges joined across the period are valleys between facing faces (0, -+h, p/2)
    theta = np.arccos((p * p / 4 - h * h) / (p * p / 4 + h * h))
    assert OffsetSurface(tile, period=(p, p)).edge_weight == pytest.approx(2 * theta * p)
    assert OffsetSurface(tile).edge_weight == 0.0  # open border: no valley edges


def test_periodic_tile_and_tiled_face_give_exact_distances():
    tile = pyramids(2, 2, [[0.8, 0.3], [1.4, 0.6]], pitch=0.5)
    profile = UniformProfile(0.0, 0.3)
    v = VertexSampler(
        SurfaceSampler(tile), profile, definition="distance", period=(1.0, 1.0)
    ).sample(np.random.default_rng(51), 20_000)
    np.testing.assert_allclose(
        MeshDistance(tile_copies(tile, 5)).distance(v.position)[0], v.depth, rtol=1e-9, atol=1e-12
    )
    face = TiledSurfaceSampler([tile], np.zeros((3, 3), int), pitch=(1.0, 1.0))
    v = VertexSampler(face, profile, definition="distance").sample(
        np.random.default_rng(52), 20_000
    )
    big = tile_copies(tile, 7) + np.array(
        [1.0, 1.0, 0]
    )  # the 3 x 3 face and two rings of neighbours
    np.testing.assert_allclose(
        MeshDistance(big).distance(v.position)[0], v.depth, rtol=1e-9, atol=1e-12
    )
    assert set(np.unique(v.patch)) == set(range(9))


def test_non_manifold_or_misoriented_meshes_are_refused_for_distance():
    flipped = v_groove(1.0, 1.0, 1.0)
    flipped[0] = flipped[0][[0, 2, 1]]
    with pytest.raises(ConfigError, match="wound"):
        OffsetSurface(flipped)
    fan = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, z]] for z in (0.0, 0.5, 1.0)], float)
    with pytest.raises(ConfigError, match="more than two faces"):
        OffsetSurface(fan)


def test_lengths_may_be_given_with_units():
    assert ExponentialProfile("20 nm").mean == pytest.approx(20 * nm)
    assert UniformProfile("10 nm", "0.1 um").hi == pytest.approx(100 * nm)
    assert MultiExponentialProfile([1, 1], ["5 nm", 0.001]).means == pytest.approx([5 * nm, 1e-3])
    with pytest.raises(ConfigError, match=r"mean: .* has no unit"):
        ExponentialProfile("20")
