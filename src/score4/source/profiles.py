"""Depth profiles: laws of the depth d >= 0 (mm) of contamination below a surface.

Each profile has ``pdf(d)``, ``cdf(d)`` and exact, truncatable sampling:
:class:`TableProfile` (piecewise-linear table, e.g. from a file with a ``# unit: nm`` header),
:class:`ExponentialProfile`, :class:`MultiExponentialProfile`, :class:`UniformProfile`,
:class:`TruncatedGaussianProfile` and :class:`ZeroDepth`. Minimum and maximum depths truncate
a profile exactly (inverse CDF restricted to the window), so no draw is wasted on them and no
value outside them can be produced. :mod:`score4.source.depth` places vertices with them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from score4.common.units import length_text, parse_quantity

from ..errors import ConfigError
from .sampling import DiscreteSampler, PiecewiseLinear, read_table

__all__ = [
    "DepthProfile",
    "ExponentialProfile",
    "MultiExponentialProfile",
    "TableProfile",
    "TruncatedGaussianProfile",
    "UniformProfile",
    "ZeroDepth",
    "check_window",
]


def _length(value: float | str, name: str) -> float:
    """A length in mm from a float (mm) or a string with a unit (``"20 nm"``)."""
    if isinstance(value, str):
        return parse_quantity(value, "length", name)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{name}: expected a length in mm or a string like '20 nm', got {value!r}"
        ) from None


def _positive(value: float | str, name: str) -> float:
    value = _length(value, name)
    if not (np.isfinite(value) and value > 0):
        raise ConfigError(f"{name}: got {length_text(value)}; must be a finite length > 0")
    return value


def check_window(
    min_: float | str, max_: float | str, names: tuple[str, str] = ("min_depth", "max_depth")
) -> tuple[float, float]:
    """Validate a depth window ``0 <= lo <= hi`` (``hi`` may be infinite)."""
    lo, hi = _length(min_, names[0]), _length(max_, names[1])
    if not np.isfinite(lo) or lo < 0:
        raise ConfigError(f"{names[0]}: got {length_text(lo)}; must be a finite length >= 0")
    if np.isnan(hi) or hi < lo:
        raise ConfigError(
            f"{names[0]} / {names[1]}: {length_text(lo)} > {length_text(hi)}; need {names[0]} <= "
            f"{names[1]}"
        )
    return lo, hi


class DepthProfile(ABC):
    """A law of the depth below the surface, in mm, with exact truncated sampling."""

    #: How messages name the profile ("exponential profile", "depth table t.txt").
    description = "depth profile"

    @abstractmethod
    def pdf(self, d: ArrayLike) -> np.ndarray:
        """Normalised density (1/mm) at depths ``d``."""

    @abstractmethod
    def cdf(self, d: ArrayLike) -> np.ndarray:
        """Probability of a depth <= ``d``."""

    @abstractmethod
    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        """``n`` exact draws of the profile truncated to ``[lo, hi]``."""

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` depths in mm."""
        return self.sample_between(rng, n, 0.0, np.inf)

    def mass(self, lo: float, hi: float) -> float:
        """Probability of ``lo <= d <= hi``."""
        return float(self.cdf(hi) - self.cdf(lo))

    def truncated(self, lo: float = 0.0, hi: float = np.inf) -> DepthProfile:
        """This profile restricted to ``[lo, hi]`` and renormalised."""
        lo, hi = check_window(lo, hi)
        if lo == 0.0 and hi == np.inf:
            return self
        if not self.mass(lo, hi) > 0:
            raise ConfigError(
                f"min_depth / max_depth: the {self.description} has no probability between "
                f"{length_text(lo)} and {length_text(hi)}; widen the window"
            )
        return TruncatedProfile(self, lo, hi)


class TruncatedProfile(DepthProfile):
    """A profile restricted to ``[lo, hi]`` (use :meth:`DepthProfile.truncated`)."""

    def __init__(self, base: DepthProfile, lo: float, hi: float) -> None:
        self.base, self.lo, self.hi = base, lo, hi
        self._mass = base.mass(lo, hi)

    def pdf(self, d: ArrayLike) -> np.ndarray:
        d = np.asarray(d, dtype=float)
        return np.where((d >= self.lo) & (d <= self.hi), self.base.pdf(d) / self._mass, 0.0)

    def cdf(self, d: ArrayLike) -> np.ndarray:
        d = np.clip(np.asarray(d, dtype=float), self.lo, self.hi)
        return np.clip((self.base.cdf(d) - self.base.cdf(self.lo)) / self._mass, 0.0, 1.0)

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        return self.base.sample_between(rng, n, max(lo, self.lo), min(hi, self.hi))


class TableProfile(DepthProfile):
    """Depth density linear between table points, zero outside them.

    Parameters
    ----------
    depths
        (k,) strictly increasing depths in mm, >= 0.
    weights
        (k,) density values at ``depths`` (any normalisation), >= 0, not all zero.

    Notes
    -----
    Normalised by the exact trapezoid integral (uneven spacing is fine) and sampled by exact
    inversion of the piecewise-quadratic CDF.
    """

    def __init__(self, depths: ArrayLike, weights: ArrayLike, what: str = "depth table") -> None:
        self._law = PiecewiseLinear(depths, weights, what=what, xname="depth")
        self.description = (
            f"{what} (depths {length_text(self._law.x[0])} to {length_text(self._law.x[-1])})"
        )
        self.depths, self.weights = self._law.x, self._law.w

    @classmethod
    def from_file(cls, path: str | Path, unit: str | None = None) -> TableProfile:
        """Read ``depth weight`` rows; the unit comes from a ``# unit: nm`` header or ``unit``."""
        depths, weights = read_table(path, "length", unit=unit, what="depth table", xname="depth")
        return cls(depths, weights, what=f"depth table {path}")

    def pdf(self, d: ArrayLike) -> np.ndarray:
        return self._law.pdf(d)

    def cdf(self, d: ArrayLike) -> np.ndarray:
        return self._law.cdf(d)

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        return self._law.sample(rng, n, lo, hi)


class ExponentialProfile(DepthProfile):
    """Density ``exp(-d / mean) / mean``; ``mean`` in mm or as a string with a unit."""

    description = "exponential profile"

    def __init__(self, mean: float | str) -> None:
        self.mean = _positive(mean, "mean")

    def pdf(self, d: ArrayLike) -> np.ndarray:
        d = np.asarray(d, dtype=float)
        return np.where(d >= 0, np.exp(-np.maximum(d, 0) / self.mean) / self.mean, 0.0)

    def cdf(self, d: ArrayLike) -> np.ndarray:
        return -np.expm1(-np.maximum(np.asarray(d, dtype=float), 0.0) / self.mean)

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        return _truncated_exponential(rng.random(n), self.mean, max(lo, 0.0), hi)


def _truncated_exponential(u: np.ndarray, mean: ArrayLike, lo: float, hi: float) -> np.ndarray:
    """Inverse CDF of exponentials of ``mean`` truncated to ``[lo, hi]`` (cancellation-free)."""
    span = np.expm1(-(hi - lo) / np.asarray(mean))
    return np.minimum(lo - mean * np.log1p(u * span), hi)


class MultiExponentialProfile(DepthProfile):
    """A weighted sum of exponentials: density ``sum_i w_i exp(-d / m_i) / m_i``.

    Parameters
    ----------
    weights
        (k,) non-negative component weights (normalised here), not all zero.
    means
        (k,) mean depths in mm, > 0.
    """

    description = "multi-exponential profile"

    def __init__(self, weights: ArrayLike, means: ArrayLike) -> None:
        w = np.asarray(weights, dtype=float).ravel()
        m = np.array(
            [
                _length(v, f"means[{i}]")
                for i, v in enumerate(np.atleast_1d(np.asarray(means, dtype=object)).ravel())
            ]
        )
        if len(w) != len(m) or len(w) == 0:
            raise ConfigError(
                f"weights / means: need the same non-zero number of each, got {len(w)} and {len(m)}"
            )
        for i, mean in enumerate(m):
            _positive(mean, f"means[{i}]")
        if not np.isfinite(w).all() or (w < 0).any() or not (w > 0).any():
            raise ConfigError(f"weights: got {w.tolist()}; must be finite, >= 0 and not all zero")
        self.weights, self.means = w / w.sum(), m

    def pdf(self, d: ArrayLike) -> np.ndarray:
        d = np.asarray(d, dtype=float)[..., None]
        dens = (self.weights * np.exp(-np.maximum(d, 0) / self.means) / self.means).sum(axis=-1)
        return np.where(d[..., 0] >= 0, dens, 0.0)

    def cdf(self, d: ArrayLike) -> np.ndarray:
        x = np.maximum(np.asarray(d, dtype=float), 0.0)[..., None]
        return (self.weights * -np.expm1(-x / self.means)).sum(axis=-1)

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        lo = max(lo, 0.0)
        # component masses inside the window, so the mixture stays exact when truncated
        mass = self.weights * (np.exp(-lo / self.means) - np.exp(-hi / self.means))
        comp = DiscreteSampler(mass, "component masses").sample(rng, n)
        return _truncated_exponential(rng.random(n), self.means[comp], lo, hi)


class UniformProfile(DepthProfile):
    """Uniform depth between ``min`` and ``max`` (mm, or strings with a unit)."""

    description = "uniform profile"

    def __init__(self, min: float | str, max: float | str) -> None:
        self.lo, self.hi = check_window(min, max, ("min", "max"))
        if not (np.isfinite(self.hi) and self.hi > self.lo):
            raise ConfigError(f"max: got {max!r}; must be finite and > min {min!r}")

    def pdf(self, d: ArrayLike) -> np.ndarray:
        d = np.asarray(d, dtype=float)
        return np.where((d >= self.lo) & (d <= self.hi), 1.0 / (self.hi - self.lo), 0.0)

    def cdf(self, d: ArrayLike) -> np.ndarray:
        return np.clip((np.asarray(d, dtype=float) - self.lo) / (self.hi - self.lo), 0.0, 1.0)

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        a, b = max(lo, self.lo), min(hi, self.hi)
        return a + rng.random(n) * (b - a)


class TruncatedGaussianProfile(DepthProfile):
    """Gaussian of ``mean`` and ``sigma`` restricted to ``[lower, upper]`` (default ``[0, inf)``).

    Lengths in mm, or strings with a unit.
    """

    description = "truncated Gaussian profile"

    def __init__(
        self,
        mean: float | str,
        sigma: float | str,
        lower: float | str = 0.0,
        upper: float | str = np.inf,
    ) -> None:
        self.mean = _length(mean, "mean")
        if not np.isfinite(self.mean) or self.mean < 0:
            raise ConfigError(f"mean: got {length_text(self.mean)}; must be a finite depth >= 0")
        self.sigma = _positive(sigma, "sigma")
        self.lower, self.upper = check_window(lower, upper, ("lower", "upper"))
        self._norm = self._phi_mass(self.lower, self.upper)
        if not self._norm > 0:
            raise ConfigError(
                f"lower / upper: no probability between {length_text(self.lower)} and "
                f"{length_text(self.upper)} for this Gaussian"
            )

    def _phi_mass(self, lo: float, hi: float) -> float:
        from scipy.special import ndtr

        a, b = (lo - self.mean) / self.sigma, (hi - self.mean) / self.sigma
        return float(ndtr(-a) - ndtr(-b)) if a > 0 else float(ndtr(b) - ndtr(a))

    def pdf(self, d: ArrayLike) -> np.ndarray:
        d = np.asarray(d, dtype=float)
        z = (d - self.mean) / self.sigma
        dens = np.exp(-0.5 * z * z) / (self.sigma * np.sqrt(2 * np.pi) * self._norm)
        return np.where((d >= self.lower) & (d <= self.upper), dens, 0.0)

    def cdf(self, d: ArrayLike) -> np.ndarray:
        from scipy.special import ndtr

        x = np.clip(np.asarray(d, dtype=float), self.lower, self.upper)
        z0, z = (self.lower - self.mean) / self.sigma, (x - self.mean) / self.sigma
        if z0 > 0:  # upper tail: differences of survival functions keep the precision
            return np.clip((ndtr(-z0) - ndtr(-z)) / self._norm, 0.0, 1.0)
        return np.clip((ndtr(z) - ndtr(z0)) / self._norm, 0.0, 1.0)

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        from scipy.special import ndtr, ndtri

        lo, hi = max(lo, self.lower), min(hi, self.upper)
        a, b = (lo - self.mean) / self.sigma, (hi - self.mean) / self.sigma
        u = rng.random(n)
        if a > 0:  # upper tail: invert the survival function to keep precision
            z = -ndtri(ndtr(-a) - u * (ndtr(-a) - ndtr(-b)))
        else:
            z = ndtri(ndtr(a) + u * (ndtr(b) - ndtr(a)))
        return np.clip(self.mean + self.sigma * z, lo, hi)


class ZeroDepth(DepthProfile):
    """All vertices exactly on the surface (a point mass at depth 0; ``pdf`` is 0 elsewhere)."""

    description = "zero-depth profile"

    def pdf(self, d: ArrayLike) -> np.ndarray:
        return np.zeros_like(np.asarray(d, dtype=float))

    def cdf(self, d: ArrayLike) -> np.ndarray:
        return (np.asarray(d, dtype=float) >= 0).astype(float)

    def mass(self, lo: float, hi: float) -> float:
        return 1.0 if lo <= 0.0 <= hi else 0.0

    def truncated(self, lo: float = 0.0, hi: float = np.inf) -> DepthProfile:
        lo, hi = check_window(lo, hi)
        if lo > 0:
            raise ConfigError(
                f"min_depth: got {length_text(lo)} but the depth profile is zero depth; use "
                "min_depth 0"
            )
        return self

    def sample_between(self, rng: np.random.Generator, n: int, lo: float, hi: float) -> np.ndarray:
        return np.zeros(n)
