"""fit_random_surface: generate -> fit -> parameters recovered; real measured file -> sane
values."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.surface.fit import autocorrelation, fit_acf, fit_psd, fit_random_surface
from score4.surface.heightmap import HeightMap
from score4.surface.processing import fill_missing, level_plane
from score4.surface.random import gaussian_random_surface, random_surface, self_affine_surface
from score4.surface.readers import read_topography

DATA = Path(__file__).parent / "data" / "topography"
ACF_KEYS = {
    "model",
    "nx",
    "ny",
    "pitch_x",
    "pitch_y",
    "sq",
    "skewness",
    "kurtosis",
    "corr_length_x",
    "corr_length_y",
}
SA_KEYS = {
    "model",
    "nx",
    "ny",
    "pitch_x",
    "pitch_y",
    "sq",
    "skewness",
    "kurtosis",
    "hurst",
    "long_cutoff",
    "short_cutoff",
}


@pytest.mark.parametrize(("acf", "n"), [("gaussian", 256), ("exponential", 512)])
def test_correlation_lengths_and_acf_type_recovered(acf, n):
    # mean of 4 seeds; one map scatters by ~3 % (Gaussian, 256^2) / ~5 % (exponential, 512^2)
    # around the truth (seeds 0-9 measured). Tolerance 10 %.
    lx, ly = 0.008, 0.005
    fits = [
        fit_random_surface(
            gaussian_random_surface(
                n, n, 0.001, sq=0.001, corr_length_x=lx, corr_length_y=ly, acf=acf, seed=s
            )
        )
        for s in range(4)
    ]
    assert {f["model"] for f in fits} == {acf}
    assert np.mean([f["corr_length_x"] for f in fits]) == pytest.approx(lx, rel=0.10)
    assert np.mean([f["corr_length_y"] for f in fits]) == pytest.approx(ly, rel=0.10)
    assert fits[0]["sq"] == pytest.approx(0.001, rel=1e-9)


def test_fit_is_directly_usable_by_the_generator():
    hm = gaussian_random_surface(
        128,
        96,
        "1 um",
        sq="0.4 um",
        corr_length_x="6 um",
        corr_length_y="4 um",
        skewness=0.6,
        kurtosis=3.8,
        seed=11,
    )
    fit = fit_random_surface(hm)
    assert set(fit) == ACF_KEYS
    assert fit["skewness"] == pytest.approx(0.6, abs=1e-3)
    assert fit["kurtosis"] == pytest.approx(3.8, rel=1e-3)
    twin = random_surface(**fit, seed=12)
    assert twin.shape == hm.shape
    assert (twin.pitch_x, twin.pitch_y) == (hm.pitch_x, hm.pitch_y)
    assert np.std(twin.heights) == pytest.approx(np.std(hm.heights), rel=1e-9)
    refit = fit_random_surface(twin)
    assert refit["corr_length_x"] == pytest.approx(
        fit["corr_length_x"], rel=0.15
    )  # two maps: ~2x one-map scatter


@pytest.mark.parametrize(("hurst", "lam_l", "lam_s"), [(0.8, 0.064, 0.008), (0.3, 0.032, 0.006)])
def test_self_affine_parameters_recovered(hurst, lam_l, lam_s):
    # periodic 256^2 maps, 4 seeds measured: H within 0.06, short cut-off within 5 %,
    # long cut-off within 20 %. Tolerances: 0.1, 15 %, 30 %.
    hm = self_affine_surface(
        256,
        256,
        0.001,
        hurst=hurst,
        sq=0.001,
        long_cutoff=lam_l,
        short_cutoff=lam_s,
        periodic=True,
        seed=0,
    )
    fit = fit_random_surface(hm, model="self_affine")
    assert set(fit) == SA_KEYS
    assert fit["hurst"] == pytest.approx(hurst, abs=0.1)
    assert fit["short_cutoff"] == pytest.approx(lam_s, rel=0.15)
    assert fit["long_cutoff"] == pytest.approx(lam_l, rel=0.30)
    again = random_surface(**fit, seed=1)
    assert again.shape == hm.shape


def test_hurst_of_a_non_periodic_map():
    # Hann-windowed PSD; no cut-offs inside the band: H within 0.1 (measured 0.01-0.04, seeds 0-3)
    hm = self_affine_surface(256, 256, 0.001, hurst=0.5, sq=0.001, seed=2)
    fit = fit_psd(hm)
    assert fit["hurst"] == pytest.approx(0.5, abs=0.1)
    assert fit["short_cutoff"] == pytest.approx(
        0.002, rel=0.2
    )  # no drop seen: the Nyquist wavelength


def test_autocorrelation_is_one_at_zero_lag_and_symmetric():
    hm = gaussian_random_surface(40, 30, 1.0, sq=1.0, corr_length_x=4.0, seed=0)
    acf = autocorrelation(hm)
    assert acf.shape == (59, 79)
    assert acf[0, 0] == pytest.approx(1.0)
    assert acf[0, 3] == pytest.approx(acf[0, -3])  # point symmetry of the linear ACF
    assert acf[2, 5] == pytest.approx(acf[-2, -5])


def test_fit_on_a_real_measured_file_gives_sane_values():
    # ISO 25178-71 sample from sdfio (see tests/data/topography/README.md): 48 x 32 points,
    # 2 um x 3 um pitch, 40 missing points
    hm = fill_missing(level_plane(read_topography(DATA / "sdfio_iso1_surface_binary.sdf")))
    with warnings.catch_warnings():
        warnings.simplefilter(
            "ignore"
        )  # the tiny sample may need its grid raised for the generator
        acf_fit = fit_random_surface(hm)
        sa_fit = fit_random_surface(hm, model="self_affine")
    for fit in (acf_fit, sa_fit):
        assert all(np.isfinite(v) for k, v in fit.items() if k != "model")
        assert 0.3e-3 < fit["sq"] < 1e-3  # the file's Sq is 0.54 um
        assert fit["kurtosis"] > fit["skewness"] ** 2 + 1
    assert acf_fit["model"] in ("gaussian", "exponential")
    assert 0.002 <= acf_fit["corr_length_x"] < 48 * 0.002
    assert 0.003 <= acf_fit["corr_length_y"] < 32 * 0.003
    assert 0 < sa_fit["hurst"] <= 1
    assert sa_fit["short_cutoff"] < sa_fit["long_cutoff"] <= 32 * 0.003 + 1e-12
    random_surface(**acf_fit, seed=0)
    random_surface(**sa_fit, seed=0)


def test_fit_acf_reports_both_models():
    fits = fit_acf(
        gaussian_random_surface(128, 128, 1.0, sq=1.0, corr_length_x=6.0, acf="exponential", seed=3)
    )
    assert set(fits) == {"gaussian", "exponential"}
    assert fits["exponential"]["rms_residual"] < fits["gaussian"]["rms_residual"]


def test_moments_outside_the_generator_region_are_moved_with_a_warning():
    z = np.zeros((64, 64))
    z[::16, ::16] = 1.0  # a few spikes: kurtosis ~ 250
    z += np.random.default_rng(0).normal(scale=1e-3, size=z.shape)
    # all three adjustments warn: kurtosis, and both correlation lengths (raised to 2 pitches)
    with pytest.warns(UserWarning, match=r"kurtosis|corr_length_[xy] raised") as record:
        fit = fit_random_surface(HeightMap(z, 1.0, 1.0))
    assert any("kurtosis" in str(w.message) for w in record)
    assert fit["kurtosis"] == 20.0


def test_bad_input():
    z = np.random.default_rng(0).normal(size=(32, 32))
    z[3, 4] = np.nan
    with pytest.raises(ConfigError, match="missing"):
        fit_random_surface(HeightMap(z, 1.0, 1.0))
    with pytest.raises(ConfigError, match="flat"):
        fit_random_surface(HeightMap(np.ones((16, 16)), 1.0, 1.0))
    with pytest.raises(ConfigError, match="model"):
        fit_random_surface(
            HeightMap(np.random.default_rng(1).normal(size=(16, 16)), 1.0, 1.0), model="pink"
        )
    with pytest.raises(ConfigError):
        HeightMap(np.full((8, 8), np.nan), 1.0, 1.0)  # NaN-only maps cannot even be built
