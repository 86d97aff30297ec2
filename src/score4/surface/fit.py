"""Estimate random-surface model parameters from a height map, to generate more surfaces like it.

:func:`fit_random_surface` returns a dict that is directly the keyword arguments of
:func:`score4.surface.random.random_surface`::

    params = fit_random_surface(measured)            # ACF model, auto: gaussian or exponential
    twin = random_surface(**params, seed=1)
    fractal = random_surface(**fit_random_surface(measured, model="self_affine"), seed=1)

Keys (lengths in mm):

* always: ``model``, ``nx``, ``ny``, ``pitch_x``, ``pitch_y``, ``sq``, ``skewness``, ``kurtosis``;
* ``model`` ``"gaussian"`` / ``"exponential"``: ``corr_length_x``, ``corr_length_y``;
* ``model`` ``"self_affine"``: ``hurst``, ``long_cutoff``, ``short_cutoff``.

Methods
-------
Height moments
    Sq, Ssk, Sku (ISO, 3 for a Gaussian) of the heights minus their mean. No plane is removed:
    level the map first (:func:`score4.surface.processing.level_plane`) if it is tilted.
ACF
    The areal autocorrelation of the centred heights by FFT: circular when
    ``hm.metadata["periodic"]`` is true, otherwise zero-padded and divided per lag by the number
    of overlapping points (unbiased). It is normalised to 1 at zero lag. Both models
    ACF = exp(-r^2) and exp(-r), r^2 = (dx/l_x)^2 + (dy/l_y)^2, are fitted by least squares to
    the lags inside twice the 0.1-crossing along each axis where the ACF is >= 0.1; the model
    with the smaller residual wins ("auto"). The mean removal biases the ACF down by about
    (l/L)^2 terms: correlation lengths come out a few % short at 20 lengths per side.
PSD
    Radially averaged |FFT|^2 in log-spaced bins (16 per decade) up to the Nyquist wavenumber
    π/pitch; non-periodic maps get a Hann window and lose their two lowest wavenumbers. Model:
    plateau below q_L, power law q^(-2-2H) up to q_S, a constant floor (noise, or nothing)
    above. Fitted by maximum (Whittle) likelihood over the Fourier modes: H on a 0.01 grid,
    q_L on a quarter-bin grid, q_S between bins (the bin holding q_S is left out). Wavelengths
    are λ = 2π/q. Without a visible roll-off long_cutoff is the map side; without a visible drop
    short_cutoff is 2 * pitch. Resolution: q_S to about one bin (15 %); q_L is set by the few
    longest-wavelength modes and scatters by 20-50 %.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import ConfigError, Score4Warning
from . import random as rs
from .heightmap import HeightMap

_ACF_CORE = 0.1  # fit the ACF where it is above this value
_HURST_GRID = np.linspace(0.01, 1.0, 100)


# ----------------------------------------------------------------------------- checks, moments
def _valid_heights(hm: HeightMap) -> np.ndarray:
    if hm.has_missing:
        raise ConfigError(
            f"heights: the map has {int(np.isnan(hm.heights).sum())} missing (NaN) points; "
            "fill them first (score4.surface.processing.fill_missing)"
        )
    z = hm.heights - hm.heights.mean()
    if not np.any(z):
        raise ConfigError("heights: the map is flat; no roughness parameters can be fitted")
    return z


def height_moments(z: np.ndarray) -> dict[str, float]:
    """Sq, Ssk and Sku (ISO: 3 for a Gaussian) of already centred heights."""
    sq = float(np.sqrt(np.mean(z**2)))
    return {
        "sq": sq,
        "skewness": float(np.mean(z**3) / sq**3),
        "kurtosis": float(np.mean(z**4) / sq**4),
    }


# ----------------------------------------------------------------------------- ACF
def autocorrelation(hm: HeightMap) -> np.ndarray:
    """Normalised areal ACF of the centred heights, lags in FFT order (index [j, i] = lag (i px, j
    py)).

    Circular for maps with ``metadata["periodic"]``, else linear and unbiased; negative lags are
    at the end of each axis.
    """
    import scipy.fft

    z = _valid_heights(hm)
    ny, nx = z.shape
    if hm.metadata.get("periodic"):
        spec = scipy.fft.rfft2(z)
        acf = scipy.fft.irfft2(spec * spec.conj(), s=z.shape)
        return acf / acf[0, 0]
    shape = (scipy.fft.next_fast_len(2 * ny), scipy.fft.next_fast_len(2 * nx))
    spec = scipy.fft.rfft2(z, s=shape)
    ones = scipy.fft.rfft2(np.ones_like(z), s=shape)
    acf = scipy.fft.irfft2(spec * spec.conj(), s=shape)
    counts = np.rint(scipy.fft.irfft2(ones * ones.conj(), s=shape))
    keep_y = np.r_[0:ny, shape[0] - ny + 1 : shape[0]]  # drop lags that no pair of points has
    keep_x = np.r_[0:nx, shape[1] - nx + 1 : shape[1]]
    acf = acf[np.ix_(keep_y, keep_x)] / np.maximum(counts[np.ix_(keep_y, keep_x)], 1)
    return acf / acf[0, 0]


def _lags(n: int, pitch: float) -> np.ndarray:
    """Signed lags in the FFT order of an axis of length n (n odd: 2m-1 lags, or periodic n)."""
    import scipy.fft

    return scipy.fft.fftfreq(n, 1.0 / n) * pitch


def _axis_crossing(profile: np.ndarray, level: float) -> int:
    """First index where a 1-D ACF profile (lag 0 first) drops below ``level``; len if never."""
    below = np.nonzero(profile < level)[0]
    return int(below[0]) if below.size else len(profile)


def fit_acf(hm: HeightMap) -> dict[str, dict[str, float]]:
    """Least-squares fit of both ACF models; returns per model corr_length_x/_y and rms residual."""
    from scipy import optimize

    acf = autocorrelation(hm)
    ny, nx = acf.shape
    dy = _lags(ny, hm.pitch_y)[:, None]
    dx = _lags(nx, hm.pitch_x)[None, :]
    half_x, half_y = (nx + 1) // 2, (ny + 1) // 2
    ix = _axis_crossing(acf[0, :half_x], _ACF_CORE)
    iy = _axis_crossing(acf[:half_y, 0], _ACF_CORE)
    window = (
        (np.abs(dx) <= 2 * ix * hm.pitch_x)
        & (np.abs(dy) <= 2 * iy * hm.pitch_y)
        & (acf >= _ACF_CORE)
    )
    rho, ddx, ddy = (
        acf[window],
        np.broadcast_to(dx, acf.shape)[window],
        np.broadcast_to(dy, acf.shape)[window],
    )
    start = np.log(
        [
            max(_axis_crossing(acf[0, :half_x], math.exp(-1)), 1) * hm.pitch_x,
            max(_axis_crossing(acf[:half_y, 0], math.exp(-1)), 1) * hm.pitch_y,
        ]
    )
    out = {}
    for model in rs.ACF_MODELS:
        res = optimize.least_squares(
            lambda p, m=model: rs.acf_model(m, ddx, ddy, math.exp(p[0]), math.exp(p[1])) - rho,
            start,
        )
        out[model] = {
            "corr_length_x": float(math.exp(res.x[0])),
            "corr_length_y": float(math.exp(res.x[1])),
            "rms_residual": float(np.sqrt(np.mean(res.fun**2))),
        }
    return out


# ----------------------------------------------------------------------------- PSD
def radial_psd(
    hm: HeightMap, bins_per_decade: int = 16
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Radially averaged power spectrum in log-spaced bins of angular wavenumber q (1/mm).

    Returns the mean q, the mean power and the number of Fourier modes of each non-empty bin,
    q from 2π / (longest side) up to π / max(pitch). The power is in arbitrary units (only its
    shape is used). Non-periodic maps get a Hann window, whose main lobe smears the two
    lowest wavenumbers: those are left out.
    """
    import scipy.fft
    from scipy import signal

    z = _valid_heights(hm)
    ny, nx = z.shape
    periodic = bool(hm.metadata.get("periodic"))
    if not periodic:
        z = z * np.outer(signal.windows.hann(ny, sym=False), signal.windows.hann(nx, sym=False))
    power = np.abs(scipy.fft.rfft2(z)) ** 2
    q = rs._angular_wavenumbers(z.shape, hm.pitch_x, hm.pitch_y)
    q_min = 2 * np.pi / max(nx * hm.pitch_x, ny * hm.pitch_y) * (1 if periodic else 2.5)
    q_max = np.pi / max(hm.pitch_x, hm.pitch_y)
    n_bins = max(math.ceil(bins_per_decade * math.log10(q_max / q_min)), 4)
    edges = np.geomspace(q_min * (1 - 1e-9), q_max * (1 + 1e-9), n_bins + 1)
    idx = np.digitize(q.ravel(), edges) - 1
    ok = (idx >= 0) & (idx < n_bins)
    counts = np.bincount(idx[ok], minlength=n_bins)
    q_sum = np.bincount(idx[ok], q.ravel()[ok], minlength=n_bins)
    p_sum = np.bincount(idx[ok], power.ravel()[ok], minlength=n_bins)
    full = counts > 0
    return q_sum[full] / counts[full], p_sum[full] / counts[full], counts[full]


def _whittle_law(
    logq: np.ndarray, p: np.ndarray, n: np.ndarray, log_q0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Negative log-likelihood of a plateau + power law on these bins, for every H of _HURST_GRID.

    Whittle likelihood: each Fourier mode's power is exponential with mean C(q); the amplitude A
    of C = A max(q, q0)^(-2-2H) takes its maximum-likelihood value for each H.
    """
    log_f = -(2 + 2 * _HURST_GRID[:, None]) * np.maximum(logq, log_q0)[None, :]
    amp = (n * p * np.exp(-log_f)).sum(axis=1) / n.sum()
    return n.sum() * (np.log(amp) + 1) + (n * log_f).sum(axis=1), amp


def fit_psd(hm: HeightMap) -> dict[str, float]:
    """Hurst exponent and long/short cut-off wavelengths (mm) from the radial PSD.

    Maximum (Whittle) likelihood over all Fourier modes of the model: plateau below q_L, power
    law q^(-2-2H) up to q_S, a constant floor (noise or nothing) above q_S. q_L on a grid of
    quarter bins, q_S between bins, H on a grid of 0.01 in (0, 1].
    """
    q, c, n = radial_psd(hm)
    if q.size < 6:
        raise ConfigError(
            f"heights: map of shape {hm.shape} is too small for a PSD fit; rule: at least 6 "
            "wavenumber bins"
        )
    logq = np.log(q)
    c = np.maximum(
        c, c.max() * 1e-10
    )  # a noise floor: exact zeros above a cut-off would make the likelihood unbounded
    best = (np.inf, 0.0, 0.0, 0.0)
    for b in range(
        3, q.size
    ):  # bins 0..b follow the law, bin b+1 holds q_S (left out: mixed), then the floor
        above = slice(b + 2, None)
        floor_nll = (
            n[above].sum() * (np.log((n[above] * c[above]).sum() / n[above].sum()) + 1)
            if b + 2 < q.size
            else 0.0
        )
        for log_q0 in np.linspace(logq[0], logq[b - 2], 4 * (b - 1)):
            nll, _ = _whittle_law(logq[: b + 1], c[: b + 1], n[: b + 1], log_q0)
            k = int(np.argmin(nll))
            if nll[k] + floor_nll < best[0]:
                log_qs = logq[b + 1] if b + 1 < q.size else np.inf
                best = (
                    float(nll[k] + floor_nll),
                    float(_HURST_GRID[k]),
                    float(log_q0),
                    float(log_qs),
                )
    _, hurst, log_q0, log_qs = best
    side = min(hm.shape[1] * hm.pitch_x, hm.shape[0] * hm.pitch_y)
    nyquist = 2 * max(hm.pitch_x, hm.pitch_y)
    short = max(2 * np.pi / math.exp(log_qs), nyquist) if np.isfinite(log_qs) else nyquist
    long = min(2 * np.pi / math.exp(log_q0), side) if log_q0 > logq[0] else side
    return {
        "hurst": hurst,
        "long_cutoff": float(max(long, 1.05 * short)),
        "short_cutoff": float(short),
    }


# ----------------------------------------------------------------------------- public fit
def _usable_moments(m: dict[str, float]) -> tuple[float, float]:
    """Moments moved onto the edge of the generator's region when outside it (with a warning)."""
    s, k = m["skewness"], m["kurtosis"]
    s2 = float(np.clip(s, -rs.MAX_ABS_SKEWNESS, rs.MAX_ABS_SKEWNESS))
    floor = s2**2 * (1 + rs.MARGIN_PER_SKEW2) + 1 + rs.MIN_KURTOSIS_MARGIN
    k2 = float(np.clip(k, floor, rs.MAX_KURTOSIS))
    if (s2, k2) != (s, k):
        warnings.warn(
            f"fit_random_surface: skewness {s:.3g}, kurtosis {k:.3g} moved to {s2:.3g}, {k2:.3g}, "
            "the edge of the generator's supported region",
            Score4Warning,
            stacklevel=3,
        )
    return s2, k2


def _usable_corr_lengths(fit: dict[str, float], hm: HeightMap) -> dict[str, float]:
    """Grid large enough for the generator: n * pitch >= 5 l, pitch <= l / 2 (with warnings)."""
    out: dict[str, float] = {"nx": hm.shape[1], "ny": hm.shape[0]}
    for axis, pitch in (("x", hm.pitch_x), ("y", hm.pitch_y)):
        corr = max(fit[f"corr_length_{axis}"], pitch / rs.MAX_PITCH_PER_CORR_LENGTH)
        if corr != fit[f"corr_length_{axis}"]:
            warnings.warn(
                f"fit_random_surface: corr_length_{axis} raised to 2 * pitch_{axis} = {corr:g} mm "
                "(the map does not resolve its correlation)",
                Score4Warning,
                stacklevel=3,
            )
        need = math.ceil(rs.MIN_CORR_LENGTHS_PER_SIDE * corr / pitch)
        if need > out[f"n{axis}"]:
            warnings.warn(
                f"fit_random_surface: n{axis} raised from {out[f'n{axis}']} to {need} to hold "
                f"{rs.MIN_CORR_LENGTHS_PER_SIDE:g} correlation lengths",
                Score4Warning,
                stacklevel=3,
            )
            out[f"n{axis}"] = need
        out[f"corr_length_{axis}"] = corr
    return out


def fit_random_surface(hm: HeightMap, model: str = "auto") -> dict:
    """Parameters of a random-surface model that reproduces ``hm`` statistically.

    Parameters
    ----------
    hm
        Height map without missing points (fill or crop them first).
    model
        ``"auto"`` (the better of the Gaussian and exponential ACF fits), ``"gaussian"``,
        ``"exponential"`` or ``"self_affine"``.

    Returns
    -------
    dict
        Keyword arguments of :func:`score4.surface.random.random_surface` (see the module
        docstring for the keys). ``skewness``/``kurtosis`` outside the generator's supported
        region, or correlation lengths the grid cannot hold, are adjusted with a warning.
    """
    choices = ("auto", *rs.MODELS)
    if model not in choices:
        raise ConfigError(f"model: unknown model {model!r}; use one of: {', '.join(choices)}")
    moments = height_moments(_valid_heights(hm))
    s, k = _usable_moments(moments)
    base = {
        "nx": hm.shape[1],
        "ny": hm.shape[0],
        "pitch_x": hm.pitch_x,
        "pitch_y": hm.pitch_y,
        "sq": moments["sq"],
        "skewness": s,
        "kurtosis": k,
    }
    if model == "self_affine":
        return {"model": model, **base, **fit_psd(hm)}
    fits = fit_acf(hm)
    if model == "auto":
        model = min(rs.ACF_MODELS, key=lambda m: fits[m]["rms_residual"])
    return {"model": model, **base, **_usable_corr_lengths(fits[model], hm)}
