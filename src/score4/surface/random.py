"""Seeded random rough surfaces: Gaussian random fields, self-affine fractals, non-Gaussian heights.

Every generator returns a :class:`~score4.surface.heightmap.HeightMap` (mm) with mean height 0
and is reproducible from ``seed`` (an int or a :class:`numpy.random.Generator`).

Conventions
-----------
Grid
    ``nx`` x ``ny`` samples at ``pitch_x`` / ``pitch_y`` (mm, or strings such as ``"0.5 um"``).
Autocorrelation (``acf``) and correlation lengths ``corr_length_x`` = l_x, ``corr_length_y`` = l_y
    With r = sqrt((dx/l_x)^2 + (dy/l_y)^2) the normalised autocorrelation function is
    ``"gaussian"``: ACF = exp(-r^2); ``"exponential"``: ACF = exp(-r).
    So l is the lag where the ACF falls to 1/e. ISO 25178-2 Sal (s = 0.2) is the lag where it falls
    to 0.2 along the shortest direction: Sal = sqrt(ln 5) * min(l_x, l_y) = 1.2686 min(l) for the
    Gaussian ACF and Sal = ln 5 * min(l_x, l_y) = 1.6094 min(l) for the exponential one
    (see :data:`SAL_PER_CORR_LENGTH`). A finite map with its mean removed shows a slightly shorter
    Sal (by a few % at 20 correlation lengths per side).
Synthesis
    Circulant embedding: the target ACF is sampled on the periodic generation grid (lags wrapped),
    its FFT is the power spectrum, white Gaussian noise is coloured by its square root. On the
    periodic grid the covariance of the field is exactly the wrapped target ACF.
Height scale
    The realised map is shifted to mean 0 and scaled so that its own Sq (or rms slope) equals the
    target exactly, not only in expectation.
Periodic maps (``periodic=True``)
    The map is one period: the duplicated edge sample is *not* included. Column ``nx`` would equal
    column 0 (period nx * pitch_x), so two copies placed side by side (``numpy.hstack``) join
    without a step. :func:`score4.surface.processing.close_periodic` appends the duplicate edge
    when a closed tile is wanted. ``metadata["periodic"]`` is True.
Non-periodic maps (default)
    Generated on a grid enlarged by several correlation lengths (the long cut-off for fractals)
    and cropped, so opposite edges are uncorrelated.
Non-Gaussian heights (``skewness``, ``kurtosis``; Sku convention: 3 for a Gaussian)
    Johnson translator system (Hu & Tonder 1992): the Gaussian field is mapped through a monotone
    function, so the spatial ordering of heights is kept. Its ranks are replaced by normal scores,
    a Johnson S_U (kurtosis above the lognormal line), S_L (on it) or S_B (below it) curve is
    fitted to the moments, and the fit is corrected until the *realised* map has the target Ssk
    and Sku (to 1e-3). The transform changes the ACF a little (correlation length within ~10 %
    for |Ssk| <= 1, more for stronger skew). Supported region (:func:`check_moments`):
    Sku > Ssk^2 + 1 is the bound for any distribution (ConfigError "impossible"); this module
    accepts |Ssk| <= 3 and 1.05 Ssk^2 + 1.2 <= Sku <= 20 (checked on maps of 128 x 128 points and
    more; a smaller map may not reach heavy tails and then raises ConfigError).
Self-affine fractals
    Isotropic power spectrum C(q) ∝ q^(-2-2H) between q_L = 2π/long_cutoff and
    q_S = 2π/short_cutoff, constant below q_L (roll-off plateau), zero above q_S (q is the angular
    wavenumber, wavelength λ = 2π/q). Normalised to a target Sq or rms slope; the rms slope is
    :func:`rms_slope`, the same definition as metrology's Sdq.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from score4.common.units import length_text, parse_quantity

from ..errors import ConfigError
from .heightmap import HeightMap

ACF_MODELS = ("gaussian", "exponential")
MODELS = (*ACF_MODELS, "self_affine")
#: Sal (ISO 25178-2, s = 0.2) divided by the correlation length, per ACF model.
SAL_PER_CORR_LENGTH = {"gaussian": math.sqrt(math.log(5.0)), "exponential": math.log(5.0)}
#: The map side must hold at least this many correlation lengths.
MIN_CORR_LENGTHS_PER_SIDE = 5.0
#: The pitch must not exceed this fraction of the correlation length.
MAX_PITCH_PER_CORR_LENGTH = 0.5
#: Padding (in correlation lengths) added before cropping a non-periodic map: the ACF there is
#: ~1e-4 (Gaussian) or ~2.5e-3 (exponential).
_PAD_CORR_LENGTHS = {"gaussian": 3.0, "exponential": 6.0}
MAX_ABS_SKEWNESS = 3.0
MIN_KURTOSIS_MARGIN = 0.2
MARGIN_PER_SKEW2 = 0.05
MAX_KURTOSIS = 20.0
_MOMENT_TOLERANCE = 1e-3

Seed = int | np.random.Generator | None


# ----------------------------------------------------------------------------- input checks
def _length(value: float | str, name: str) -> float:
    """A positive finite length in mm from a float (mm) or a string with a unit."""
    x = parse_quantity(value, "length", name) if isinstance(value, str) else value
    if isinstance(x, bool) or not isinstance(x, (int, float, np.floating, np.integer)):
        raise ConfigError(
            f"{name}: expected a length (float in mm or string such as '5 um'), got {value!r}"
        )
    if not (math.isfinite(x) and x > 0):
        raise ConfigError(f"{name}: must be a positive finite length, got {value!r}")
    return float(x)


def _finite_real(value: object) -> float | None:
    """``value`` as a float if it is a finite real number (bool excluded), else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        return None
    x = float(value)
    return x if math.isfinite(x) else None


def _count(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 4:
        raise ConfigError(f"{name}: must be an integer number of samples >= 4, got {value!r}")
    return int(value)


def _grid(
    nx: int, ny: int, pitch_x: float | str, pitch_y: float | str | None
) -> tuple[int, int, float, float]:
    px = _length(pitch_x, "pitch_x")
    py = px if pitch_y is None else _length(pitch_y, "pitch_y")
    return _count(nx, "nx"), _count(ny, "ny"), px, py


def _check_corr_length(corr: float, n: int, pitch: float, axis: str) -> None:
    """ConfigError unless the grid resolves and holds enough correlation lengths along one axis."""
    if pitch > MAX_PITCH_PER_CORR_LENGTH * corr:
        raise ConfigError(
            f"corr_length_{axis}: {length_text(corr)} is too short for pitch_{axis} = "
            f"{length_text(pitch)}; "
            f"rule: pitch_{axis} <= {MAX_PITCH_PER_CORR_LENGTH:g} * corr_length_{axis}"
        )
    if n * pitch < MIN_CORR_LENGTHS_PER_SIDE * corr:
        raise ConfigError(
            f"corr_length_{axis}: {length_text(corr)} is too long for a map side of n{axis} * "
            f"pitch_{axis} = {length_text(n * pitch)}; "
            f"rule: n{axis} * pitch_{axis} >= {MIN_CORR_LENGTHS_PER_SIDE:g} * corr_length_{axis}"
        )


def _rng(seed: Seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


# ----------------------------------------------------------------------------- spectra
def _wrapped_lags(n: int, pitch: float) -> np.ndarray:
    """Lags 0, p, 2p, ... then negative ones, as the FFT orders them (periodic distance)."""
    i = np.arange(n)
    return np.minimum(i, n - i) * pitch


def acf_model(acf: str, dx: np.ndarray, dy: np.ndarray, lx: float, ly: float) -> np.ndarray:
    """Normalised model ACF at lags (dx, dy); see the module docstring for the definitions."""
    r2 = (np.asarray(dx) / lx) ** 2 + (np.asarray(dy) / ly) ** 2
    return np.exp(-r2) if acf == "gaussian" else np.exp(-np.sqrt(r2))


def _acf_amplitude(
    shape: tuple[int, int], px: float, py: float, acf: str, lx: float, ly: float
) -> np.ndarray:
    """sqrt of the power spectrum (rfft2 layout) of the wrapped ACF: circulant embedding."""
    import scipy.fft

    dy = _wrapped_lags(shape[0], py)[:, None]
    dx = _wrapped_lags(shape[1], px)[None, :]
    psd = scipy.fft.rfft2(acf_model(acf, dx, dy, lx, ly)).real
    return np.sqrt(np.clip(psd, 0.0, None))  # tiny negative values are round-off / wrap artefacts


def _angular_wavenumbers(shape: tuple[int, int], px: float, py: float) -> np.ndarray:
    """|q| = 2π |f| on the rfft2 grid, in 1/mm."""
    import scipy.fft

    qy = 2 * np.pi * scipy.fft.fftfreq(shape[0], py)[:, None]
    qx = 2 * np.pi * scipy.fft.rfftfreq(shape[1], px)[None, :]
    return np.hypot(qx, qy)


def _self_affine_amplitude(
    shape: tuple[int, int], px: float, py: float, hurst: float, q_long: float, q_short: float
) -> np.ndarray:
    """sqrt of C(q) ∝ max(q, q_L)^(-2-2H) for q <= q_S, 0 above and at q = 0."""
    q = _angular_wavenumbers(shape, px, py)
    amp = np.maximum(q, q_long) ** (-1.0 - hurst)
    amp[(q > q_short * (1 + 1e-12)) | (q == 0)] = 0.0
    return amp


def _colour_noise(
    amplitude: np.ndarray, shape: tuple[int, int], rng: np.random.Generator
) -> np.ndarray:
    """Real field whose spectrum is |amplitude|^2 times white noise."""
    import scipy.fft

    white = rng.standard_normal(shape)
    return scipy.fft.irfft2(scipy.fft.rfft2(white) * amplitude, s=shape)


def _generation_shape(
    nx: int, ny: int, pad_x: float, pad_y: float, px: float, py: float, periodic: bool
) -> tuple[int, int]:
    import scipy.fft

    if periodic:
        return ny, nx
    gy = scipy.fft.next_fast_len(ny + math.ceil(pad_y / py), real=True)
    gx = scipy.fft.next_fast_len(nx + math.ceil(pad_x / px), real=True)
    return gy, gx


# ----------------------------------------------------------------------------- normalisation
def rms_slope(z: np.ndarray, pitch_x: float, pitch_y: float) -> float:
    """Root mean square gradient of the triangulated map (metrology's Sdq definition).

    Forward differences averaged per grid cell:
    mean over cells of [(Δx_bottom² + Δx_top²)/2/px² + (Δy_left² + Δy_right²)/2/py²], square root.
    """
    dx = np.diff(z, axis=1) / pitch_x
    dy = np.diff(z, axis=0) / pitch_y
    gx2 = 0.5 * (dx[:-1, :] ** 2 + dx[1:, :] ** 2)
    gy2 = 0.5 * (dy[:, :-1] ** 2 + dy[:, 1:] ** 2)
    return float(np.sqrt(np.mean(gx2 + gy2)))


def _standardise(z: np.ndarray) -> np.ndarray:
    z = z - z.mean()
    sd = z.std()
    if not sd > 0:
        raise ConfigError(
            "heights: the generated field is flat; increase the grid or the roughness parameters"
        )
    return z / sd


# ----------------------------------------------------------------------------- Johnson system
@dataclass(frozen=True)
class JohnsonCurve:
    """A Johnson translation y = f((u - gamma) / delta) of a standard normal u.

    ``family`` is ``"SU"`` (f = sinh), ``"SB"`` (f = logistic), ``"SL"`` (f = exp) or ``"normal"``
    (f = identity); ``sign`` = -1 mirrors y for negative skewness.
    """

    family: str
    gamma: float
    delta: float
    sign: float = 1.0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        from scipy import special

        t = (np.asarray(u, dtype=float) - self.gamma) / self.delta
        f: Callable[[np.ndarray], np.ndarray] = {
            "SU": np.sinh,
            "SB": special.expit,
            "SL": np.exp,
            "normal": lambda v: v,
        }[self.family]
        return self.sign * f(t)


def check_moments(skewness: float, kurtosis: float) -> None:
    """Raise ConfigError unless (Ssk, Sku) is in the region this module can generate.

    Sku is the ISO kurtosis (3 for a Gaussian). Any distribution has Sku >= Ssk^2 + 1;
    the supported region is |Ssk| <= MAX_ABS_SKEWNESS (3),
    1.05 Ssk^2 + 1.2 <= Sku <= MAX_KURTOSIS (20). Near the bound the S_B fit needs extreme
    parameters; very heavy tails need more points than a map has.
    """
    given: tuple[tuple[str, object], ...] = (("skewness", skewness), ("kurtosis", kurtosis))
    for name, v in given:  # checked at run time: callers may pass anything
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float, np.floating, np.integer))
            or not math.isfinite(v)
        ):
            raise ConfigError(f"{name}: must be a finite number, got {v!r}")
    bound = skewness**2 + 1
    if kurtosis <= bound:
        raise ConfigError(
            f"kurtosis: {kurtosis:g} is impossible with skewness {skewness:g}; rule: kurtosis > "
            f"skewness^2 + 1 = {bound:g} (ISO Sku, 3 for a Gaussian)"
        )
    if abs(skewness) > MAX_ABS_SKEWNESS:
        raise ConfigError(
            f"skewness: {skewness:g} is outside the supported range; rule: |skewness| <= "
            f"{MAX_ABS_SKEWNESS:g}"
        )
    floor = bound + MIN_KURTOSIS_MARGIN + MARGIN_PER_SKEW2 * skewness**2
    if kurtosis < floor:
        raise ConfigError(
            f"kurtosis: {kurtosis:g} is too close to the bound skewness^2 + 1 = {bound:g} for the "
            f"Johnson system; rule: kurtosis >= {1 + MARGIN_PER_SKEW2:g} * skewness^2 + "
            f"{1 + MIN_KURTOSIS_MARGIN:g} = {floor:g}"
        )
    if kurtosis > MAX_KURTOSIS:
        raise ConfigError(
            f"kurtosis: {kurtosis:g} is outside the supported range; rule: kurtosis <= "
            f"{MAX_KURTOSIS:g}"
        )


def _lognormal_w(skew: float) -> float:
    """w = exp(sigma^2) of the lognormal with skewness ``skew`` >= 0: (w - 1)(w + 2)^2 = skew^2."""
    from scipy import optimize

    if skew == 0:
        return 1.0
    return optimize.brentq(
        lambda w: (w - 1) * (w + 2) ** 2 - skew**2, 1.0, 1.0 + skew**2 + 1.0, xtol=1e-15
    )


def _lognormal_kurtosis(w: float) -> float:
    return w**4 + 2 * w**3 + 3 * w**2 - 3


def _su_skew_kurt(gamma: float, delta: float) -> tuple[float, float]:
    """Closed-form skewness and kurtosis of y = sinh((u - gamma)/delta) (Johnson 1949)."""
    w = math.exp(delta**-2)
    om = gamma / delta
    var = 0.5 * (w - 1) * (w * math.cosh(2 * om) + 1)
    m3 = -0.25 * math.sqrt(w) * (w - 1) ** 2 * (w * (w + 2) * math.sinh(3 * om) + 3 * math.sinh(om))
    m4 = (
        0.125
        * (w - 1) ** 2
        * (
            w**2 * (w**4 + 2 * w**3 + 3 * w**2 - 3) * math.cosh(4 * om)
            + 4 * w**2 * (w + 2) * math.cosh(2 * om)
            + 3 * (2 * w + 1)
        )
    )
    return m3 / var**1.5, m4 / var**2


@functools.cache
def _gauss_hermite() -> tuple[np.ndarray, np.ndarray]:
    """160-point nodes and normalised weights: E[g(u)] = sum(w g(u)) for u ~ N(0, 1).

    Computed on first use, not at import: every run imports this module via the config.
    """
    u, w = np.polynomial.hermite_e.hermegauss(160)
    return u, w / w.sum()


def _sample_skew_kurt(y: np.ndarray) -> tuple[float, float]:
    d = y - y.mean()
    m2 = np.mean(d * d)
    return float(np.mean(d**3) / m2**1.5), float(np.mean(d**4) / m2**2)


def _sb_skew_kurt(gamma: float, delta: float) -> tuple[float, float]:
    """Skewness and kurtosis of y = logistic((u - gamma)/delta) by Gauss-Hermite quadrature."""
    from scipy import special

    u, w = _gauss_hermite()
    y = special.expit((u - gamma) / delta)
    d = y - w @ y
    m2 = w @ d**2
    return float(w @ d**3 / m2**1.5), float(w @ d**4 / m2**2)


def _solve_family(
    moments: Callable[[float, float], tuple[float, float]],
    skew: float,
    kurt: float,
    delta_hi: float,
) -> tuple[float, float]:
    """Nested 1-D solves: for each delta the gamma giving ``skew``; then the delta giving ``kurt``.

    For fixed delta < delta_hi the skewness runs monotonically from 0 (gamma = 0) towards the
    lognormal value as gamma -> -inf, and along the curve of constant skewness the kurtosis runs
    monotonically between the bound and the lognormal line (Johnson 1949).
    """
    from scipy import optimize

    def gamma_for(delta: float) -> float:
        if skew == 0:
            return 0.0
        g = lambda gm: moments(gm, delta)[0] - skew  # noqa: E731
        side = (
            -1.0 if g(-1e-3 * delta) > g(1e-3 * delta) else 1.0
        )  # the sign of gamma that raises skew
        far = side * delta
        while g(far) < 0 and abs(far) < 60 * delta:
            far *= 2
        return (
            optimize.brentq(g, far, 0.0, xtol=1e-12)
            if side < 0
            else optimize.brentq(g, 0.0, far, xtol=1e-12)
        )

    def kurt_gap(delta: float) -> float:
        try:
            return moments(gamma_for(delta), delta)[1] - kurt
        except ValueError:  # skew out of reach at this delta: it behaves as on the lognormal line
            return k_ln - kurt

    k_ln = _lognormal_kurtosis(_lognormal_w(skew))

    delta = optimize.brentq(
        kurt_gap, 0.05 if moments is _sb_skew_kurt else 0.25, delta_hi, xtol=1e-10
    )
    return gamma_for(delta), delta


def fit_johnson(skewness: float, kurtosis: float) -> JohnsonCurve:
    """Johnson curve whose (continuous) distribution has the given skewness and ISO kurtosis."""
    check_moments(skewness, kurtosis)
    return _fit_johnson(skewness, kurtosis)


def _fit_johnson(skewness: float, kurtosis: float) -> JohnsonCurve:
    s, sign = abs(skewness), (1.0 if skewness >= 0 else -1.0)
    s = 0.0 if s < 1e-9 else s  # below this the lognormal line is numerically at w = 1
    if s == 0 and kurtosis == 3:
        return JohnsonCurve("normal", 0.0, 1.0)
    w = _lognormal_w(s)
    k_ln = _lognormal_kurtosis(w)
    if s > 0 and abs(kurtosis - k_ln) < 1e-9 * k_ln:
        return JohnsonCurve("SL", 0.0, 1 / math.sqrt(math.log(w)), sign)
    delta_hi = 1e3 if s == 0 else (1 / math.sqrt(math.log(w))) * (1 - 1e-9)
    # positive skew of y = f((u - gamma)/delta) needs gamma < 0 for both families
    if kurtosis > k_ln:
        gamma, delta = _solve_family(_su_skew_kurt, s, kurtosis, delta_hi)
        return JohnsonCurve("SU", gamma, delta, sign)
    gamma, delta = _solve_family(_sb_skew_kurt, s, kurtosis, delta_hi)
    return JohnsonCurve("SB", gamma, delta, sign)


def _clamp_target(skew: float, kurt: float) -> tuple[float, float]:
    """Keep corrected targets inside the region where the Johnson fit is defined."""
    skew = float(np.clip(skew, -MAX_ABS_SKEWNESS - 0.5, MAX_ABS_SKEWNESS + 0.5))
    return skew, float(np.clip(kurt, skew**2 + 1 + 0.5 * MIN_KURTOSIS_MARGIN, 1e4))


def johnson_translate(z: np.ndarray, skewness: float, kurtosis: float) -> np.ndarray:
    """Map a field monotonically onto heights with the given sample skewness and ISO kurtosis.

    The ranks of ``z`` are kept; the output has mean 0, standard deviation 1, and its own sample
    Ssk and Sku equal the targets within 1e-3 (ConfigError if the map is too small for that).
    """
    from scipy import special

    check_moments(skewness, kurtosis)
    flat = np.asarray(z, dtype=float).ravel()
    if skewness == 0 and kurtosis == 3:
        return _standardise(flat).reshape(np.shape(z))
    n = flat.size
    u = special.ndtri((np.arange(n) + 0.5) / n)  # normal scores of ranks 0..n-1
    target = (float(skewness), float(kurtosis))
    for _ in range(30):
        try:
            y = _fit_johnson(*_clamp_target(*target))(u)
        except (ValueError, ArithmeticError) as exc:  # root bracketing failed at an extreme target
            raise ConfigError(
                f"kurtosis: no Johnson curve found for skewness {skewness:g}, kurtosis "
                f"{kurtosis:g} ({exc})"
            ) from exc
        got = _sample_skew_kurt(y)
        err = (skewness - got[0], kurtosis - got[1])
        if abs(err[0]) < _MOMENT_TOLERANCE and abs(err[1]) < _MOMENT_TOLERANCE * kurtosis:
            break
        target = (
            target[0] + err[0],
            target[1] + err[1],
        )  # fixed-point correction for the finite sample
    else:
        raise ConfigError(
            f"kurtosis: cannot reach skewness {skewness:g}, kurtosis {kurtosis:g} on a map of {n} "
            f"points (got {got[0]:.3g}, {got[1]:.3g}); use a larger map or milder moments"
        )
    out = np.empty(n)
    out[np.argsort(flat, kind="stable")] = _standardise(y)
    return out.reshape(np.shape(z))


# ----------------------------------------------------------------------------- generators
def _finish(
    z: np.ndarray,
    px: float,
    py: float,
    scale: float,
    skewness: float,
    kurtosis: float,
    metadata: dict,
    by_slope: bool = False,
) -> HeightMap:
    """Apply the height distribution and scale (Sq or rms slope) to a coloured Gaussian field."""
    z = johnson_translate(z, skewness, kurtosis)
    z = z * (scale / (rms_slope(z, px, py) if by_slope else 1.0))
    return HeightMap(z, px, py, metadata=metadata)


def gaussian_random_surface(
    nx: int,
    ny: int,
    pitch_x: float | str,
    *,
    sq: float | str,
    corr_length_x: float | str,
    corr_length_y: float | str | None = None,
    acf: str = "gaussian",
    skewness: float = 0.0,
    kurtosis: float = 3.0,
    pitch_y: float | str | None = None,
    periodic: bool = False,
    seed: Seed = None,
) -> HeightMap:
    """Random rough surface with a Gaussian or exponential ACF and a target Sq.

    Parameters
    ----------
    nx, ny
        Number of samples along x and y (>= 4).
    pitch_x, pitch_y
        Sample spacing (mm or string with unit); ``pitch_y`` defaults to ``pitch_x``.
    sq
        Root mean square height Sq of the realised map (exact).
    corr_length_x, corr_length_y
        Correlation lengths l_x, l_y: ACF = exp(-r^2) or exp(-r), r^2 = (dx/l_x)^2 + (dy/l_y)^2.
        ``corr_length_y`` defaults to ``corr_length_x``. Rules: pitch <= l/2 and
        n * pitch >= 5 l along each axis.
    acf
        ``"gaussian"`` or ``"exponential"``.
    skewness, kurtosis
        Target Ssk and Sku (ISO, 3 for a Gaussian); see :func:`check_moments`.
    periodic
        True: one period without the duplicated edge sample (tiles seamlessly).
    seed
        int, :class:`numpy.random.Generator` or None.

    Returns
    -------
    HeightMap
        Heights in mm with mean 0; ``metadata`` records the generator, parameters and seed.
    """
    nx, ny, px, py = _grid(nx, ny, pitch_x, pitch_y)
    if acf not in ACF_MODELS:
        raise ConfigError(f"acf: unknown model {acf!r}; use one of: {', '.join(ACF_MODELS)}")
    sq_ = _length(sq, "sq")
    lx = _length(corr_length_x, "corr_length_x")
    ly = lx if corr_length_y is None else _length(corr_length_y, "corr_length_y")
    _check_corr_length(lx, nx, px, "x")
    _check_corr_length(ly, ny, py, "y")
    check_moments(skewness, kurtosis)
    pad = _PAD_CORR_LENGTHS[acf]
    shape = _generation_shape(nx, ny, pad * lx, pad * ly, px, py, periodic)
    field = _colour_noise(_acf_amplitude(shape, px, py, acf, lx, ly), shape, _rng(seed))[:ny, :nx]
    meta = {
        "generator": "gaussian_random_surface",
        "model": acf,
        "sq": sq_,
        "corr_length_x": lx,
        "corr_length_y": ly,
        "skewness": skewness,
        "kurtosis": kurtosis,
        "periodic": periodic,
        "seed": seed if not isinstance(seed, np.random.Generator) else "Generator",
    }
    return _finish(field, px, py, sq_, skewness, kurtosis, meta)


def self_affine_surface(
    nx: int,
    ny: int,
    pitch_x: float | str,
    *,
    hurst: float,
    sq: float | str | None = None,
    rms_slope: float | None = None,
    long_cutoff: float | str | None = None,
    short_cutoff: float | str | None = None,
    skewness: float = 0.0,
    kurtosis: float = 3.0,
    pitch_y: float | str | None = None,
    periodic: bool = False,
    seed: Seed = None,
) -> HeightMap:
    """Self-affine (fractal) random surface, C(q) ∝ q^(-2-2H) between two cut-offs.

    Parameters
    ----------
    nx, ny, pitch_x, pitch_y, skewness, kurtosis, periodic, seed
        As in :func:`gaussian_random_surface`.
    hurst
        Hurst exponent H, 0 < H <= 1 (fractal dimension 3 - H).
    sq, rms_slope
        Exactly one: the realised Sq (mm) or rms slope (dimensionless, :func:`rms_slope`).
    long_cutoff
        Roll-off wavelength λ_L = 2π/q_L: the spectrum is flat at longer wavelengths. Default and
        maximum: the shorter map side, n * pitch.
    short_cutoff
        Shortest wavelength λ_S = 2π/q_S present. Default and minimum: 2 * max(pitch) (Nyquist).

    Returns
    -------
    HeightMap
        Heights in mm with mean 0.
    """
    nx, ny, px, py = _grid(nx, ny, pitch_x, pitch_y)
    h = _finite_real(hurst)
    if h is None or not (0 < h <= 1):
        raise ConfigError(f"hurst: {hurst!r} is outside the allowed range; rule: 0 < hurst <= 1")
    if (sq is None) == (rms_slope is None):
        raise ConfigError("sq, rms_slope: give exactly one of them to set the height scale")
    slope = None if rms_slope is None else _finite_real(rms_slope)
    if rms_slope is not None and (slope is None or slope <= 0):
        raise ConfigError(
            f"rms_slope: must be a positive number (dimensionless), got {rms_slope!r}"
        )
    side = min(nx * px, ny * py)
    lam_s = 2 * max(px, py) if short_cutoff is None else _length(short_cutoff, "short_cutoff")
    lam_l = side if long_cutoff is None else _length(long_cutoff, "long_cutoff")
    if lam_s < 2 * max(px, py) * (1 - 1e-9):
        raise ConfigError(
            f"short_cutoff: {length_text(lam_s)} is below the Nyquist wavelength; "
            f"rule: short_cutoff >= 2 * pitch = {length_text(2 * max(px, py))}"
        )
    if lam_l > side * (1 + 1e-9):
        raise ConfigError(
            f"long_cutoff: {length_text(lam_l)} exceeds the map; "
            f"rule: long_cutoff <= min(nx*pitch_x, ny*pitch_y) = {length_text(side)}"
        )
    if lam_l <= lam_s:
        raise ConfigError(
            f"long_cutoff: {length_text(lam_l)} must be longer than short_cutoff = "
            f"{length_text(lam_s)}"
        )
    check_moments(skewness, kurtosis)
    shape = _generation_shape(nx, ny, lam_l, lam_l, px, py, periodic)
    amp = _self_affine_amplitude(shape, px, py, h, 2 * np.pi / lam_l, 2 * np.pi / lam_s)
    field = _colour_noise(amp, shape, _rng(seed))[:ny, :nx]
    if sq is not None:
        scale = _length(sq, "sq")
    else:
        assert slope is not None  # exactly one of sq, rms_slope is given (checked above)
        scale = slope
    meta = {
        "generator": "self_affine_surface",
        "model": "self_affine",
        "hurst": float(hurst),
        "long_cutoff": lam_l,
        "short_cutoff": lam_s,
        "sq": scale if sq is not None else None,
        "rms_slope": rms_slope,
        "skewness": skewness,
        "kurtosis": kurtosis,
        "periodic": periodic,
        "seed": seed if not isinstance(seed, np.random.Generator) else "Generator",
    }
    return _finish(field, px, py, scale, skewness, kurtosis, meta, by_slope=sq is None)


def random_surface(model: str, **kwargs) -> HeightMap:
    """Dispatch on ``model``: the output of :func:`score4.surface.fit.fit_random_surface` fits here.

    ``"gaussian"`` / ``"exponential"`` call :func:`gaussian_random_surface` with ``acf=model``;
    ``"self_affine"`` calls :func:`self_affine_surface`. Other keyword arguments are passed on.
    """
    if model in ACF_MODELS:
        return gaussian_random_surface(acf=model, **kwargs)
    if model == "self_affine":
        return self_affine_surface(**kwargs)
    raise ConfigError(
        f"model: unknown random-surface model {model!r}; use one of: {', '.join(MODELS)}"
    )
