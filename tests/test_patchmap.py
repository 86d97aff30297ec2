"""Patch map of a large face: grid sizes, largest-remainder counts, random draws, geometry,
storage."""

from __future__ import annotations

import json
import math
import warnings

import h5py
import numpy as np
import pytest

from score4.errors import ConfigError, Score4Warning
from score4.surface.patchmap import (
    MAX_CELLS,
    PatchMap,
    given_patch_map,
    largest_remainder,
    make_patch_map,
    uniform_patch_map,
)

PAPER_DENSITIES = (0.3, 0.5, 0.2)


@pytest.fixture(scope="module")
def paper_map() -> PatchMap:
    return make_patch_map(("10 cm", "10 cm"), ("0.5 mm", "0.5 mm"), PAPER_DENSITIES, seed=1)


def _same(a: PatchMap, b: PatchMap) -> None:
    assert np.array_equal(a.variants, b.variants)
    assert a.variants.shape == b.variants.shape
    assert a.patch_size == b.patch_size
    assert a.densities == b.densities
    assert (a.method, a.seed) == (b.method, b.seed)


# --- the paper's example and exact counts ----------------------------------------------------


def test_paper_example_exact_counts(paper_map):
    m = paper_map
    assert (m.nx, m.ny, m.n_variants) == (200, 200, 3)
    assert m.variants.shape == (200, 200)
    assert m.face_size == pytest.approx((100.0, 100.0), rel=1e-12)
    assert m.counts.tolist() == [12000, 20000, 8000]
    assert m.fractions == pytest.approx([0.3, 0.5, 0.2], abs=1e-15)
    assert m.method == "exact"
    assert m.seed == 1
    assert m.densities == pytest.approx(PAPER_DENSITIES, rel=1e-15)


def test_exact_positions_are_shuffled(paper_map):
    # A shuffled grid has about 30 % variant 0 in the lower half of the rows (hypergeometric,
    # sigma = sqrt(N p q (1 - n/N) / n) ~ 0.0016); a blocked or sorted grid would not. Tolerance 5
    # sigma.
    half = paper_map.variants[:100]
    sigma = math.sqrt(0.3 * 0.7 * 0.5 / half.size)
    for k, d in enumerate(PAPER_DENSITIES):
        assert abs(np.mean(half == k) - d) < 5 * sigma


def test_largest_remainder_awkward_numbers():
    assert largest_remainder(7, [1 / 3, 1 / 3, 1 / 3]).tolist() == [3, 2, 2]
    assert largest_remainder(8, [1, 1, 1]).tolist() == [3, 3, 2]  # ties go to the first variants
    assert largest_remainder(10, [0.15, 0.15, 0.7]).tolist() == [2, 1, 7]
    # quotas 0.7, 0.8, 3.5: floors 0, 0, 3 leave 2 cells for the remainders 0.8 and 0.7, not 0.5
    assert largest_remainder(5, [0.14, 0.16, 0.7]).tolist() == [1, 1, 3]
    assert largest_remainder(0, [0.5, 0.5]).tolist() == [0, 0]
    assert largest_remainder(40000, PAPER_DENSITIES).tolist() == [12000, 20000, 8000]
    m = make_patch_map((7.0, 1.0), (1.0, 1.0), [1 / 3, 1 / 3, 1 / 3])
    assert m.counts.tolist() == [3, 2, 2]


def test_largest_remainder_properties_on_random_cases():
    rng = np.random.default_rng(2024)
    for _ in range(500):
        k = int(rng.integers(1, 9))
        n = int(rng.integers(0, 5000))
        w = rng.random(k) + 1e-3
        d = w / w.sum()
        q = n * d
        counts = largest_remainder(n, w)
        assert counts.sum() == n
        assert np.all(np.abs(counts - q) < 1)
        # Hamilton's rule: every class rounded up has a remainder >= every class rounded down.
        frac = q - np.floor(q)
        up = counts > np.floor(q) + 0.5
        if up.any() and (~up).any():
            assert frac[up].min() >= frac[~up].max() - 1e-9


def test_exact_counts_within_one_on_random_grids():
    rng = np.random.default_rng(99)
    for _ in range(30):
        nx, ny = (int(v) for v in rng.integers(1, 40, size=2))
        k = int(rng.integers(1, 6))
        d = rng.random(k) + 0.01
        d = d / d.sum()
        m = make_patch_map((nx * 0.25, ny * 0.75), (0.25, 0.75), d, seed=int(rng.integers(1000)))
        assert (m.nx, m.ny) == (nx, ny)
        assert m.counts.sum() == nx * ny
        assert np.all(np.abs(m.counts - nx * ny * d) < 1)


def test_seed_reproducible_and_changes_arrangement_not_counts():
    a = make_patch_map((20.0, 10.0), (0.5, 0.5), PAPER_DENSITIES, seed=5)
    b = make_patch_map((20.0, 10.0), (0.5, 0.5), PAPER_DENSITIES, seed=5)
    c = make_patch_map((20.0, 10.0), (0.5, 0.5), PAPER_DENSITIES, seed=6)
    _same(a, b)
    assert not np.array_equal(a.variants, c.variants)
    assert a.counts.tolist() == c.counts.tolist() == [240, 400, 160]


def test_random_method_binomial_within_4_sigma():
    m = make_patch_map((100.0, 100.0), (0.5, 0.5), PAPER_DENSITIES, method="random", seed=12345)
    n = m.nx * m.ny
    assert n == 40000
    assert m.method == "random"
    assert m.counts.sum() == n
    for k, d in enumerate(PAPER_DENSITIES):
        sigma = math.sqrt(d * (1 - d) / n)  # binomial standard deviation of a fraction
        assert abs(m.fractions[k] - d) < 4 * sigma
    # independent draws, not exact counts: over several seeds the counts are not all exact
    exact = [12000, 20000, 8000]
    others = [
        make_patch_map(
            (100.0, 100.0), (0.5, 0.5), PAPER_DENSITIES, method="random", seed=s
        ).counts.tolist()
        for s in range(3)
    ]
    assert any(c != exact for c in others)
    again = make_patch_map((100.0, 100.0), (0.5, 0.5), PAPER_DENSITIES, method="random", seed=12345)
    _same(m, again)


def test_seed_none_draws_a_map():
    m = make_patch_map((2.0, 2.0), (0.5, 0.5), (0.5, 0.5), seed=None)
    assert m.seed is None
    assert m.counts.tolist() == [8, 8]


# --- densities -------------------------------------------------------------------------------


def test_densities_normalised_with_warning():
    with pytest.warns(
        Score4Warning, match=r"densities: sum is 2, not 1; normalised to \[0\.3, 0\.5, 0\.2\]"
    ):
        m = make_patch_map((5.0, 2.0), (1.0, 1.0), [0.6, 1.0, 0.4])
    assert m.densities == pytest.approx((0.3, 0.5, 0.2), rel=1e-15)
    assert sum(m.densities) == pytest.approx(1.0, abs=1e-15)
    assert m.counts.tolist() == [3, 5, 2]


def test_densities_within_tolerance_do_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        m = make_patch_map((4.0, 1.0), (1.0, 1.0), [0.25, 0.25, 0.25, 0.25 + 1e-12])
    assert m.counts.tolist() == [1, 1, 1, 1]


@pytest.mark.parametrize(
    ("densities", "match"),
    [
        ([0.3, 0.8, -0.1], r"densities\[2\]: must be positive, got -0\.1"),
        ([0.5, 0.0, 0.5], r"densities\[1\]: must be positive, got 0\.0"),
        ([-1.0, -2.0], r"densities\[0\]: must be positive, got -1\.0"),
        ([0.0, 0.0], r"densities\[0\]: must be positive, got 0\.0"),
        ([0.5, float("nan")], r"densities\[1\]: must be finite, got nan"),
        ([float("inf"), 1.0], r"densities\[0\]: must be finite, got inf"),
        ([0.5, "0.5"], r"densities\[1\]: must be a positive number, got '0\.5'"),
        ([True, 0.5], r"densities\[0\]: must be a positive number, got True"),
        ([], r"densities: must hold at least one value"),
        ("0.5", r"densities: must be a sequence of positive numbers, got '0\.5'"),
        (0.5, r"densities: must be a sequence of positive numbers, got 0\.5"),
        (np.ones((2, 2)), r"densities: must be a 1-D sequence .* shape \(2, 2\)"),
    ],
)
def test_bad_densities(densities, match):
    with pytest.raises(ConfigError, match=match):
        make_patch_map((2.0, 2.0), (1.0, 1.0), densities)


def test_densities_as_numpy_array():
    m = make_patch_map((2.0, 2.0), (1.0, 1.0), np.array([0.25, 0.75]))
    assert m.counts.tolist() == [1, 3]


# --- sizes -----------------------------------------------------------------------------------


def test_size_mismatch_lists_nearest_valid_sizes():
    msg = (
        "face_size: 10.3 mm along x is not a whole number of 0.5 mm patches; "
        "nearest valid sizes 10 mm (20 patches) or 10.5 mm (21 patches)"
    )
    with pytest.raises(ConfigError) as err:
        make_patch_map((10.3, 10.0), (0.5, 0.5), [1.0])
    assert str(err.value) == msg
    with pytest.raises(
        ConfigError, match=r"face_size: 10\.3 mm along x .* 10 mm \(20 patches\) or 10\.5 mm \(21"
    ):
        make_patch_map(("1.03 cm", "1 cm"), ("500 um", "500 um"), [1.0])
    with pytest.raises(
        ConfigError,
        match=r"face_size: 2\.2 mm along y is not a whole number of 0\.3 mm patches; "
        r"nearest valid sizes 2\.1 mm \(7 patches\) or 2\.4 mm \(8 patches\)",
    ):
        make_patch_map((3.0, 2.2), (0.5, 0.3), [1.0])
    with pytest.raises(
        ConfigError, match=r"nearest valid sizes 10 mm \(20 patches\) or 10\.5 mm \(21 patches\)"
    ):
        make_patch_map(
            (10.00001, 1.0), (0.5, 0.5), [1.0]
        )  # 1e-6 relative: beyond the 1e-9 tolerance


def test_size_within_tolerance_accepted():
    m = make_patch_map(
        (10.0 * (1 + 1e-11), 0.3), (0.5, 0.1), [1.0]
    )  # 0.3 / 0.1 = 2.9999999999999996
    assert (m.nx, m.ny) == (20, 3)
    assert m.face_size == pytest.approx((10.0, 0.3), rel=1e-12)


@pytest.mark.parametrize(
    ("face", "patch", "match"),
    [
        (
            (1.0, 1.0),
            (2.0, 0.5),
            r"patch_size: 2 mm along x is larger than the face \(face_size 1 mm\)",
        ),
        ((1.0, 1.0), (0.5, 1.5), r"patch_size: 1\.5 mm along y is larger than the face"),
        ((0.0, 1.0), (0.5, 0.5), r"face_size\[0\]: must be a positive length, got 0\.0"),
        ((1.0, -1.0), (0.5, 0.5), r"face_size\[1\]: must be a positive length, got -1\.0"),
        ((1.0, 1.0), (0.5, "-2 um"), r"patch_size\[1\]: must be a positive length, got '-2 um'"),
        ((1.0, 1.0), (float("nan"), 0.5), r"patch_size\[0\]: must be a positive length, got nan"),
        ((1.0, 1.0), ("0.5", 0.5), r"patch_size\[0\]: '0\.5' has no unit"),
        ((1.0, 1.0), ("0.5 parsec", 0.5), r"patch_size\[0\]: unknown length unit"),
        ((1.0, 2.0, 3.0), (0.5, 0.5), r"face_size: must be a length or a pair \(x, y\)"),
        ((1.0, True), (0.5, 0.5), r"face_size\[1\]: must be a positive length, got True"),
        (
            (1000.0, 1000.0),
            (0.01, 0.01),
            rf"patch_size: 100000 x 100000 = .* exceed the limit of {MAX_CELLS}",
        ),
    ],
)
def test_bad_sizes(face, patch, match):
    with pytest.raises(ConfigError, match=match):
        make_patch_map(face, patch, [1.0])


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"method": "blocks"}, r"method: must be one of exact, random, tiles, got 'blocks'"),
        ({"method": "given"}, r"method: must be one of exact, random, tiles, got 'given'"),
        ({"seed": -1}, r"seed: must be an integer >= 0 or None, got -1"),
        ({"seed": 1.5}, r"seed: must be an integer >= 0 or None, got 1\.5"),
    ],
)
def test_bad_method_and_seed(kw, match):
    with pytest.raises(ConfigError, match=match):
        make_patch_map((1.0, 1.0), (0.5, 0.5), [1.0], **kw)


def test_single_length_means_square_and_units():
    m = make_patch_map("1 cm", "2.5 mm", [0.5, 0.5])
    assert (m.nx, m.ny) == (4, 4)
    assert m.patch_size == (2.5, 2.5)


# --- non-square grids and geometry -----------------------------------------------------------


@pytest.fixture
def rect_map() -> PatchMap:
    # 3 mm x 2 mm face of 0.5 mm x 0.25 mm patches: nx = 6, ny = 8
    return make_patch_map((3.0, 2.0), (0.5, 0.25), (0.25, 0.75), seed=3)


def test_non_square_grid_and_patches(rect_map):
    m = rect_map
    assert (m.nx, m.ny) == (6, 8)
    assert m.variants.shape == (8, 6)
    assert m.patch_size == (0.5, 0.25)
    assert m.face_size == (3.0, 2.0)
    assert m.counts.tolist() == [12, 36]


def test_cell_centres(rect_map):
    c = rect_map.cell_centres()
    assert c.shape == (8, 6, 2)
    assert c[0, 0].tolist() == [-1.25, -0.875]
    assert c[7, 5].tolist() == [1.25, 0.875]
    assert c[2, 3].tolist() == [-1.5 + 3.5 * 0.5, -1.0 + 2.5 * 0.25]
    assert np.all(c[:, :, 0] == c[0, :, 0][None, :])  # x depends on the column only
    assert np.all(c[:, :, 1] == c[:, 0, 1][:, None])


def test_cell_of_centres_gives_indices_back(rect_map):
    i, j = rect_map.cell_of(rect_map.cell_centres())
    jj, ii = np.indices((8, 6))
    assert np.array_equal(i, ii)
    assert np.array_equal(j, jj)
    flat_i, flat_j = rect_map.cell_of(rect_map.cell_centres().reshape(-1, 2))
    assert flat_i.shape == (48,)
    assert np.array_equal(flat_i, ii.ravel())
    assert np.array_equal(flat_j, jj.ravel())


def test_cell_of_random_points_lie_in_their_cells(rect_map):
    rng = np.random.default_rng(8)
    p = rng.uniform([-1.5, -1.0], [1.5, 1.0], size=(2000, 2))
    i, j = rect_map.cell_of(p)
    c = rect_map.cell_centres()[j, i]
    assert np.all(np.abs(p[:, 0] - c[:, 0]) <= 0.25)
    assert np.all(np.abs(p[:, 1] - c[:, 1]) <= 0.125)


def test_cell_of_border_and_outside(rect_map):
    up = np.nextafter(1.5, 2.0)
    pts = np.array(
        [
            [1.5, 1.0],  # outer corner: border cell
            [-1.5, -1.0],  # opposite corner
            [1.5, 0.1],  # right border
            [0.1, -1.0],  # bottom border
            [-1.0, -0.5],  # inner boundary: the cell with the larger index
            [up, 0.0],  # just outside
            [0.0, -1.0000001],
            [5.0, 5.0],
            [np.nan, 0.0],
        ]
    )
    i, j = rect_map.cell_of(pts)
    assert i.tolist() == [5, 0, 5, 3, 1, -1, -1, -1, -1]
    assert j.tolist() == [7, 0, 4, 0, 2, -1, -1, -1, -1]
    with pytest.raises(
        ConfigError, match=r"xy: must be an array of \(x, y\) points .* got shape \(4, 3\)"
    ):
        rect_map.cell_of(np.zeros((4, 3)))


# --- uniform and given maps ------------------------------------------------------------------


def test_uniform_patch_map():
    m = uniform_patch_map(("4 mm", "3 mm"), ("1 mm", "0.5 mm"))
    assert (m.nx, m.ny, m.n_variants) == (4, 6, 1)
    assert np.all(m.variants == 0)
    assert m.counts.tolist() == [24]
    assert m.fractions.tolist() == [1.0]
    with pytest.raises(ConfigError, match=r"face_size: 4\.1 mm along x"):
        uniform_patch_map((4.1, 3.0), (1.0, 0.5))


def test_given_patch_map():
    grid = [[0, 1, 2], [2, 2, 0]]
    m = given_patch_map(grid, (0.5, 1.0))
    assert m.method == "given"
    assert m.seed is None
    assert (m.nx, m.ny, m.n_variants) == (3, 2, 3)
    assert m.variants.tolist() == grid
    assert m.counts.tolist() == [2, 1, 3]
    assert m.densities == pytest.approx((2 / 6, 1 / 6, 3 / 6), rel=1e-15)
    assert m.face_size == (1.5, 2.0)
    m5 = given_patch_map(np.array(grid, dtype=float), "0.5 mm", n_variants=5)
    assert m5.n_variants == 5
    assert m5.counts.tolist() == [2, 1, 3, 0, 0]
    assert m5.variants.dtype.kind == "i"


@pytest.mark.parametrize(
    ("grid", "n", "match"),
    [
        (
            [[0, 1], [3, 0]],
            3,
            r"variants: value 3 at row 1, column 0 is out of range 0\.\.2 \(n_variants=3\)",
        ),
        ([[0, -1]], None, r"variants: value -1 at row 0, column 1 is out of range"),
        (
            [[0.0, 1.5]],
            None,
            r"variants: must hold integer variant indices, got 1\.5 at row 0, column 1",
        ),
        ([[0.0, np.nan]], None, r"variants: must hold integer variant indices, got nan"),
        ([0, 1, 2], None, r"variants: must be a non-empty 2-D \(ny, nx\) array, got shape \(3,\)"),
        (np.zeros((0, 3)), None, r"variants: must be a non-empty 2-D"),
        ([[True, False]], None, r"variants: must hold integer variant indices, got dtype bool"),
        ([["a", "b"]], None, r"variants: must hold integer variant indices, got dtype <U1"),
        ([[0, 1]], 0, r"n_variants: must be an integer >= 1, got 0"),
    ],
)
def test_bad_given_grid(grid, n, match):
    with pytest.raises(ConfigError, match=match):
        given_patch_map(grid, (1.0, 1.0), n_variants=n)


def test_map_is_immutable(rect_map):
    with pytest.raises(ValueError, match="read-only"):
        rect_map.variants[0, 0] = 1
    with pytest.raises(AttributeError):
        rect_map.seed = 4  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        rect_map.counts[0] = 0


def test_constructor_checks_consistency():
    with pytest.raises(
        ConfigError, match=r"densities: must be non-negative finite numbers summing to 1"
    ):
        PatchMap(np.zeros((2, 2), dtype=int), (1.0, 1.0), (0.5, 0.6))
    with pytest.raises(
        ConfigError, match=r"variants: value 2 at row 0, column 1 is out of range 0\.\.1"
    ):
        PatchMap(np.array([[0, 2]]), (1.0, 1.0), (0.5, 0.5))
    with pytest.raises(
        ConfigError, match=r"method: must be one of exact, random, tiles, given, got 'x'"
    ):
        PatchMap(np.zeros((2, 2), dtype=int), (1.0, 1.0), (1.0,), "x")


# --- storage ---------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["exact", "random"])
def test_dict_round_trip_exact_through_json(method):
    m = make_patch_map((3.0, 2.0), (0.1, 0.1), (0.2, 0.3, 0.5), method=method, seed=11)
    d = json.loads(json.dumps(m.to_dict()))
    assert d["format"] == "score4-patch-map"
    assert d["shape"] == [20, 30]
    assert d["patch_size"] == ["0.1 mm", "0.1 mm"]
    back = PatchMap.from_dict(d)
    _same(m, back)
    assert back.variants.dtype == m.variants.dtype


def test_dict_round_trip_odd_floats_and_given():
    px = 1 / 3
    m = given_patch_map(np.arange(12).reshape(3, 4) % 5, (px, 0.1 + 0.2), n_variants=7)
    back = PatchMap.from_dict(json.loads(json.dumps(m.to_dict())))
    _same(m, back)
    assert back.patch_size == (px, 0.1 + 0.2)


def test_run_length_text_is_compact_for_uniform_maps():
    m = uniform_patch_map((100.0, 100.0), (0.5, 0.5))
    d = m.to_dict()
    assert d["variants"] == "0*40000"
    assert given_patch_map([[0, 0, 1], [1, 1, 2]], 1.0).to_dict()["variants"] == "0*2,1*3,2"


def test_from_dict_list_of_rows_and_errors():
    d = {"patch_size": ["1 mm", "2 mm"], "densities": [0.5, 0.5], "variants": [[0, 1], [1, 0]]}
    m = PatchMap.from_dict(d)
    assert m.method == "given"
    assert m.face_size == (2.0, 4.0)
    assert m.counts.tolist() == [2, 2]
    good = make_patch_map((2.0, 1.0), (1.0, 1.0), (0.5, 0.5)).to_dict()
    cases = [
        ({**good, "format": "other"}, r"format: expected 'score4-patch-map', got 'other'"),
        ({**good, "format_version": 9}, r"format_version: this score4 reads version 1, got 9"),
        (
            {k: v for k, v in good.items() if k != "densities"},
            r"patch map: missing key\(s\) densities",
        ),
        ({**good, "colour": 1}, r"patch map: unknown key\(s\) colour"),
        (
            {**good, "variants": "0,1,1"},
            r"variants: the run-length text holds 3 cells, expected 2 \(shape\)",
        ),
        ({**good, "variants": "0*x,1"}, r"variants: cannot read the run-length text near '0\*x'"),
        ({**good, "variants": "0*0,1*2"}, r"variants: run-length counts must be >= 1, got 0"),
        ({**good, "shape": [1]}, r"shape: must be \[ny, nx\] with positive integers, got \[1\]"),
        (
            {**good, "variants": [[0, 1, 1]]},
            r"shape: \[1, 2\] does not match the variants grid of shape \[1, 3\]",
        ),
        ({**good, "patch_size": [1.0, "1 m"]}, None),  # floats in mm are accepted
        ({**good, "patch_size": ["1", "1 mm"]}, r"patch_size\[0\]: '1' has no unit"),
    ]
    for bad, match in cases:
        if match is None:
            assert PatchMap.from_dict(bad).patch_size == (1.0, 1000.0)
            continue
        with pytest.raises(ConfigError, match=match):
            PatchMap.from_dict(bad)


@pytest.mark.parametrize("seed", [7, None])
def test_h5_round_trip_exact(tmp_path, seed):
    m = make_patch_map((4.0, 6.0), (0.25, 0.2), (0.1, 0.6, 0.3), method="random", seed=seed)
    path = tmp_path / "map.h5"
    with h5py.File(path, "w") as f:
        m.save_h5(f.create_group("patch_map"))
    with h5py.File(path, "r") as f:
        g = f["patch_map"]
        assert g["variants"].shape == (30, 16)
        assert g.attrs["units"] == "mm"
        back = PatchMap.load_h5(g)
    _same(m, back)
    with (
        h5py.File(path, "r") as f,
        pytest.raises(ConfigError, match=r"format: group '/' holds no 'score4-patch-map'"),
    ):
        PatchMap.load_h5(f)


def test_describe(paper_map):
    text = paper_map.describe()
    assert "\n" not in text
    for part in (
        "200 x 200 patches",
        "0.5 mm x 0.5 mm",
        "100 mm x 100 mm",
        "3 variant(s)",
        "method 'exact'",
        "seed 1",
        "0: 0.3000 (12000 cells; target 0.3000)",
        "2: 0.2000 (8000 cells; target 0.2000)",
    ):
        assert part in text
