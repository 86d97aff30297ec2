"""Emitters: direction laws, energy spectra, Po-210 kinematics, nuclide names, Primaries.

Statistical tests use fixed seeds and 2e5 draws; KS and chi-square tests pass at p > 0.001.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from score4.errors import ConfigError
from score4.source.emitters import (
    ALPHA_MASS,
    PB206_MASS,
    PO210_ALPHA_ENERGY,
    PO210_RECOIL_ENERGY,
    EnergySpectrum,
    Monoenergetic,
    NuclideEmitter,
    ParticleEmitter,
    Po210Emitter,
    cosine_directions,
    hemisphere_directions,
    isotropic_directions,
    make_primaries,
    normalise_nuclide,
    normalise_particle,
    sample_directions,
)

N = 200_000
P_MIN = 1e-3


def random_normals(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


# ---------------------------------------------------------------- directions


def test_isotropic_directions_have_uniform_cos_theta_and_phi():
    u = isotropic_directions(np.random.default_rng(1), N)
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0)
    assert stats.kstest(u[:, 2], stats.uniform(-1, 2).cdf).pvalue > P_MIN
    assert (
        stats.kstest(np.arctan2(u[:, 1], u[:, 0]), stats.uniform(-np.pi, 2 * np.pi).cdf).pvalue
        > P_MIN
    )
    # uniform on the sphere: any other axis too
    assert stats.kstest(u @ np.array([0.6, 0.0, 0.8]), stats.uniform(-1, 2).cdf).pvalue > P_MIN


@pytest.mark.parametrize(("side", "sign"), [("inward", -1.0), ("outward", 1.0)])
def test_hemisphere_directions_are_uniform_on_the_chosen_side(side, sign):
    rng = np.random.default_rng(2)
    normals = random_normals(rng, N)
    u = hemisphere_directions(rng, normals, side)
    c = sign * np.einsum("ij,ij->i", u, normals)
    assert c.min() >= 0
    assert stats.kstest(c, stats.uniform(0, 1).cdf).pvalue > P_MIN


@pytest.mark.parametrize(("side", "sign"), [("inward", -1.0), ("outward", 1.0)])
def test_cosine_directions_have_density_two_cos(side, sign):
    rng = np.random.default_rng(3)
    normals = random_normals(rng, N)
    u = cosine_directions(rng, normals, side)
    c = sign * np.einsum("ij,ij->i", u, normals)
    assert c.min() >= 0
    assert stats.kstest(c, lambda x: np.clip(x, 0, 1) ** 2).pvalue > P_MIN  # CDF of density 2c
    # azimuth about the normal is uniform: the tangential part has no preferred direction
    e = np.cross(normals, [0.0, 0.0, 1.0])
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    tangential = np.einsum("ij,ij->i", u, e)
    assert abs(tangential.mean()) < 5 * tangential.std() / np.sqrt(N)


def test_directions_need_normals_and_known_kinds():
    rng = np.random.default_rng(0)
    with pytest.raises(ConfigError, match="normal"):
        sample_directions(rng, "inward", 3)
    with pytest.raises(ConfigError, match="direction"):
        sample_directions(rng, "sideways", 3, np.tile([0, 0, 1.0], (3, 1)))
    with pytest.raises(ConfigError, match="normals"):
        sample_directions(rng, "inward", 3, np.tile([0, 0, 1.0], (2, 1)))


# ---------------------------------------------------------------- energies


def test_linear_spectrum_from_file_follows_its_density(tmp_path):
    f = tmp_path / "spectrum.txt"
    f.write_text("# unit: keV\n100 0\n150 4\n400 1\n1000 0\n")
    spectrum = EnergySpectrum.from_file(f)
    e = spectrum.sample(np.random.default_rng(4), N)
    assert e.min() >= 0.1
    assert e.max() <= 1.0
    edges = np.linspace(0.1, 1.0, 31)
    assert (
        stats.chisquare(np.histogram(e, edges)[0], N * np.diff(spectrum.cdf(edges))).pvalue > P_MIN
    )


def test_histogram_spectrum_is_flat_inside_bins():
    spectrum = EnergySpectrum([1.0, 2.0, 4.0, 5.0], [3.0, 1.0, 2.0, 0.0], kind="histogram")
    e = spectrum.sample(np.random.default_rng(5), N)
    edges = np.array([1.0, 1.5, 2.0, 3.0, 4.0, 4.5, 5.0])
    expected = N * np.array([1.5, 1.5, 0.5, 0.5, 1.0, 1.0]) / 6
    assert stats.chisquare(np.histogram(e, edges)[0], expected).pvalue > P_MIN


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: EnergySpectrum([1.0, 2.0], [1.0, 1.0], kind="histogram"), "last row"),
        (lambda: EnergySpectrum([1.0, 2.0], [1.0, 1.0], kind="steps"), "kind"),
        (lambda: EnergySpectrum([2.0, 1.0], [1.0, 1.0]), "unsorted energy"),
        (lambda: Monoenergetic(0.0), "energy"),
        (lambda: ParticleEmitter("alpha", -5.0), "energy"),
    ],
)
def test_bad_energies(build, match):
    with pytest.raises(ConfigError, match=match):
        build()


# ---------------------------------------------------------------- names


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("Pb210", "Pb210"),
        ("Po-210", "Po210"),
        ("po210", "Po210"),
        ("PB-210", "Pb210"),
        ("210Po", "Po210"),
        ("U238", "U238"),
    ],
)
def test_nuclide_names_are_normalised(name, expected):
    assert normalise_nuclide(name) == expected


@pytest.mark.parametrize(
    ("name", "match"),
    [
        ("Xx210", "unknown element"),
        ("Pb", "cannot read"),
        ("Pb50", "mass number"),
        ("Pb210m", "cannot read"),
    ],
)
def test_bad_nuclide_names(name, match):
    with pytest.raises(ConfigError, match=match):
        NuclideEmitter(name)


def test_particle_names():
    assert normalise_particle("alpha") == "alpha"
    assert normalise_particle("e-") == "e-"
    assert normalise_particle("Pb-206") == "Pb206"
    with pytest.raises(ConfigError, match="unknown name"):
        normalise_particle("electron")


# ---------------------------------------------------------------- emitters and primaries


def momentum(energy: np.ndarray, mass: float) -> np.ndarray:
    return np.sqrt(energy * (energy + 2 * mass))


def test_po210_alpha_and_recoil_are_back_to_back_with_zero_total_momentum():
    rng = np.random.default_rng(6)
    n = 20_000
    positions = rng.random((n, 3))
    prim = make_primaries(Po210Emitter(), rng, positions)
    assert prim.n_events == n
    assert len(prim) == 2 * n
    np.testing.assert_array_equal(prim.particle[0::2], "alpha")
    np.testing.assert_array_equal(prim.particle[1::2], "Pb206")
    np.testing.assert_array_equal(prim.event[0::2], prim.event[1::2])
    np.testing.assert_array_equal(prim.position[0::2], positions)
    np.testing.assert_array_equal(prim.position[1::2], positions)
    assert prim.energy[0] == PO210_ALPHA_ENERGY == 5.30433
    assert pytest.approx(0.1031, abs=2e-4) == PO210_RECOIL_ENERGY  # the textbook ~103 keV
    p_alpha = momentum(prim.energy[0::2], ALPHA_MASS)[:, None] * prim.direction[0::2]
    p_recoil = momentum(prim.energy[1::2], PB206_MASS)[:, None] * prim.direction[1::2]
    total = np.linalg.norm(p_alpha + p_recoil, axis=1)
    assert (total <= 1e-9 * np.linalg.norm(p_alpha, axis=1)).all()
    assert stats.kstest(prim.direction[0::2, 2], stats.uniform(-1, 2).cdf).pvalue > P_MIN


def test_po210_inward_alpha_goes_into_the_material():
    rng = np.random.default_rng(7)
    normals = random_normals(rng, 1000)
    prim = make_primaries(Po210Emitter("inward"), rng, np.zeros((1000, 3)), normals)
    assert (np.einsum("ij,ij->i", prim.direction[0::2], normals) <= 0).all()
    assert (np.einsum("ij,ij->i", prim.direction[1::2], normals) >= 0).all()


def test_nuclide_emitter_starts_the_ion_at_rest():
    prim = make_primaries(NuclideEmitter("Pb-210"), np.random.default_rng(0), np.zeros((5, 3)))
    np.testing.assert_array_equal(prim.particle, "Pb210")
    np.testing.assert_array_equal(prim.energy, 0.0)
    np.testing.assert_array_equal(prim.event, np.arange(5))


def test_make_primaries_carries_the_vertex_columns():
    rng = np.random.default_rng(8)
    n = 50
    depth, facet, patch = rng.random(n), rng.integers(0, 9, n), rng.integers(0, 4, n)
    prim = make_primaries(
        ParticleEmitter("e-", EnergySpectrum([0.0, 1.0], [1.0, 0.0]), "cosine_inward"),
        rng,
        rng.random((n, 3)),
        np.tile([0.0, 0.0, 1.0], (n, 1)),
        depth=depth,
        facet=facet,
        patch=patch,
    )
    assert len(prim) == n
    np.testing.assert_array_equal(prim.extra["depth"], depth)
    np.testing.assert_array_equal(prim.extra["facet"], facet)
    np.testing.assert_array_equal(prim.extra["patch"], patch)
    assert (prim.direction[:, 2] <= 0).all()
    two = make_primaries(Po210Emitter(), rng, rng.random((n, 3)), depth=depth)
    np.testing.assert_array_equal(two.extra["depth"], np.repeat(depth, 2))
    with pytest.raises(ConfigError, match="depth"):
        make_primaries(Po210Emitter(), rng, rng.random((n, 3)), depth=depth[:-1])


def test_energy_may_be_given_with_a_unit():
    assert ParticleEmitter("alpha", "5.3 MeV").energy.energy == pytest.approx(5.3)
    with pytest.raises(ConfigError, match="energy"):
        ParticleEmitter("alpha", "5.3 parsec")
