"""Beta spectrum shapes: allowed, unique forbidden, and measured shape factors.

The electron (or positron) kinetic-energy density of a branch with endpoint ``E0`` is

    N(W) ~ p W (W0 - W)^2 F0(Z, W) L0(Z, W) S(Z, W) C(W)

in units of the electron mass (``W`` total energy, ``p`` momentum, ``W0 = 1 + E0 / me``), with

* ``F0``: the point-charge relativistic Fermi function evaluated at the nuclear radius
  ``R = 1.2 A^(1/3) fm``, ``F0 = 2 (1 + g) (2 p R)^(2 g - 2) exp(pi y) |Gamma(g + i y)|^2 /
  Gamma(2 g + 1)^2`` with ``g = sqrt(1 - (alpha Z)^2)`` and ``y = +-alpha Z W / p``;
* ``L0``: the finite-size correction of the electrostatic potential, leading terms of
  Wilkinson's expansion (Hayen et al., Rev. Mod. Phys. 90, 015008 (2018), Eq. 16);
* ``S``: atomic screening by Rose's shifted-potential prescription, ``V0 = 1.13 alpha^2
  Z^(4/3)`` (Hayen et al. 2018, Sec. IV.A), ``S = p' W' F0(W') / (p W F0(W))`` with
  ``W' = W -+ V0`` (held at the value of ``W' = 1`` below it, where the prescription stops);
* ``C``: the shape factor. Allowed and non-unique forbidden branches: ``C = 1`` (the
  xi approximation, valid when ``alpha Z / (2 R)`` is much larger than ``W0``, e.g. Pb-210).
  Unique n-th forbidden: ``C = sum_k lambda_k p^(2(k-1)) q^(2(n-k+1)) / ((2k-1)! (2n-2k+3)!)``
  with ``q = W0 - W`` and the Coulomb functions ``lambda_k`` of the point charge
  (Konopinski & Uhlenbeck, Phys. Rev. 60, 308 (1941); Behrens & Buehring, Electron Radial Wave
  Functions and Nuclear Beta-decay (1982)), see :func:`unique_shape`.
  Bi-210 (first-forbidden non-unique, where the xi approximation fails): the measured
  ``C = 1 - 0.4363 W + 0.0523 W^2`` (Alekseev et al., arXiv:2005.08481, Phys. Part. Nucl. Lett.
  (2020)).

Not included: radiative and recoil corrections, atomic exchange, weak magnetism; they change
mean energies by well below 1 %.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

__all__ = [
    "ELECTRON_MASS_KEV",
    "BetaSpectrum",
    "beta_density",
    "shape_factor",
]

ELECTRON_MASS_KEV = 510.99895
ALPHA = 7.2973525693e-3
HBAR_C_OVER_ME_FM = 386.15926796  # reduced Compton wavelength of the electron, fm

#: Measured shape factors C(W) of named branches (parent, endpoint rounded to keV).
MEASURED_SHAPES: dict[str, tuple[float, ...]] = {
    # Alekseev et al. 2020 (arXiv:2005.08481): C(W) = 1 + a W + b W^2
    "Bi210": (1.0, -0.4363, 0.0523),
}


def fermi_function(z: float, w: np.ndarray, radius: float) -> np.ndarray:
    """Point-charge Fermi function at radius ``radius`` (units of hbar / me c); ``z`` < 0 for e+."""
    return np.exp(log_generalised_fermi(1, z, np.asarray(w, dtype=float), radius))


def finite_size(z: float, w: np.ndarray, radius: float) -> np.ndarray:
    """L0, leading terms of Wilkinson's expansion (Hayen et al. 2018, Eq. 16)."""
    g = np.sqrt(1.0 - (ALPHA * z) ** 2)
    az = ALPHA * z
    return (
        1.0
        + 13.0 * az * az / 60.0
        - w * radius * az * (41.0 - 26.0 * g) / (15.0 * (2.0 * g - 1.0))
        - az * radius * g * (17.0 - 2.0 * g) / (30.0 * w * (2.0 * g - 1.0))
    )


def log_generalised_fermi(k: int, z: float, w: np.ndarray, radius: float) -> np.ndarray:
    """``log F_(k-1)`` of the point charge at radius ``radius`` (``k = 1`` gives ``F0``)::

    F_(k-1) = [k (2k-1)!!]^2 4^k (2 p R)^(2 (g_k - k)) exp(pi y) |Gamma(g_k + i y)|^2
              / Gamma(2 g_k + 1)^2 (k + g_k) / (2 k),     g_k = sqrt(k^2 - (alpha Z)^2)
    """
    from scipy.special import loggamma  # scipy.special: ~0.3 s to import, beta spectra only

    p = np.sqrt(np.maximum(w * w - 1.0, 1e-300))
    g = np.sqrt(k * k - (ALPHA * z) ** 2)
    y = ALPHA * z * w / p
    double_fact = float(np.prod(np.arange(2 * k - 1, 0, -2)))
    return (
        2.0 * np.log(k * double_fact)
        + k * np.log(4.0)
        + 2.0 * (g - k) * np.log(2.0 * p * radius)
        + np.pi * y
        + 2.0 * np.real(loggamma(g + 1j * y))
        - 2.0 * np.real(loggamma(2.0 * g + 1.0))
        + np.log((k + g) / (2.0 * k))
    )


def unique_shape(n: int, z: float, w: np.ndarray, w0: float, radius: float) -> np.ndarray:
    """Shape factor of a unique n-th forbidden branch (Konopinski-Uhlenbeck with the Coulomb
    functions ``lambda_k = F_(k-1) / F_0`` of the point charge, Behrens & Buehring 1982)::

        C = (2n+1)! sum_(k=1)^(n+1) lambda_k p^(2(k-1)) q^(2(n-k+1)) / ((2k-1)! (2(n-k+1)+1)!)
    """
    p = np.sqrt(np.maximum(w * w - 1.0, 0.0))
    q = np.maximum(w0 - w, 0.0)
    log_f0 = log_generalised_fermi(1, z, w, radius)
    total = np.zeros_like(w)
    for k in range(1, n + 2):
        lam = np.exp(log_generalised_fermi(k, z, w, radius) - log_f0) if k > 1 else 1.0
        total = total + lam * p ** (2 * (k - 1)) * q ** (2 * (n - k + 1)) / (
            factorial(2 * k - 1) * factorial(2 * (n - k + 1) + 1)
        )
    return total * float(factorial(2 * n + 1))


def shape_factor(forbiddenness: str | None, parent: str = "") -> str:
    """A short description of the shape factor used for a branch."""
    if parent in MEASURED_SHAPES:
        return "measured C(W) (Alekseev et al. 2020)"
    n = _unique_order(forbiddenness)
    if n:
        return f"unique {n}{ {1: 'st', 2: 'nd', 3: 'rd'}.get(n, 'th') } forbidden"
    if not forbiddenness or forbiddenness.endswith("A"):  # ENSDF's 0A/1A: allowed
        return "allowed"
    return f"allowed shape ({forbiddenness}, xi approximation)"


def _unique_order(forbiddenness: str | None) -> int:
    if forbiddenness and forbiddenness.endswith("UF"):
        return int(forbiddenness[:-2] or 1)
    return 0


def beta_density(
    kinetic_kev: np.ndarray,
    endpoint_kev: float,
    z_daughter: int,
    a: int,
    *,
    positron: bool = False,
    forbiddenness: str | None = None,
    parent: str = "",
) -> np.ndarray:
    """Unnormalised density of the beta kinetic energy (keV) of one branch."""
    t = np.asarray(kinetic_kev, dtype=float)
    w = 1.0 + t / ELECTRON_MASS_KEV
    w0 = 1.0 + endpoint_kev / ELECTRON_MASS_KEV
    p = np.sqrt(np.maximum(w * w - 1.0, 0.0))
    q = np.maximum(w0 - w, 0.0)
    z = -float(z_daughter) if positron else float(z_daughter)
    radius = 1.2 * a ** (1.0 / 3.0) / HBAR_C_OVER_ME_FM
    ok = (p > 0) & (q > 0)
    out = np.zeros_like(t)
    wk, pk, qk = w[ok], p[ok], q[ok]
    dens = pk * wk * qk * qk
    # F0(W) S(W) = p' W' F0(W') / (p W): the screened Fermi function in one step (no 0/0 for
    # slow positrons, whose F0 underflows)
    v0 = 1.13 * ALPHA**2 * abs(z) ** (4.0 / 3.0)
    shifted = np.maximum(wk - np.sign(z) * v0, 1.0 + 1e-9)
    ps = np.sqrt(shifted * shifted - 1.0)
    dens *= ps * shifted / (pk * wk) * fermi_function(z, shifted, radius)
    dens *= finite_size(z, wk, radius)
    if parent in MEASURED_SHAPES:
        coeffs = MEASURED_SHAPES[parent]
        dens *= sum(c * wk**k for k, c in enumerate(coeffs))
    elif n := _unique_order(forbiddenness):
        dens *= unique_shape(n, z, wk, w0, radius)
    out[ok] = np.maximum(dens, 0.0)
    return out


@dataclass(frozen=True)
class BetaSpectrum:
    """A tabulated branch spectrum sampled by inverting its CDF (linear between grid points)."""

    energy_kev: np.ndarray  # (k,) grid from 0 to the endpoint
    cdf: np.ndarray  # (k,) from 0 to 1
    mean_kev: float

    @classmethod
    def build(
        cls,
        endpoint_kev: float,
        z_daughter: int,
        a: int,
        *,
        positron: bool = False,
        forbiddenness: str | None = None,
        parent: str = "",
        points: int = 2048,
    ) -> BetaSpectrum:
        # denser near both ends, where the density changes fastest
        x = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, points))
        e = endpoint_kev * x
        dens = beta_density(
            e,
            endpoint_kev,
            z_daughter,
            a,
            positron=positron,
            forbiddenness=forbiddenness,
            parent=parent,
        )
        steps = 0.5 * (dens[1:] + dens[:-1]) * np.diff(e)
        cdf = np.concatenate([[0.0], np.cumsum(steps)])
        total = cdf[-1]
        if not total > 0:
            raise ValueError(f"beta spectrum with endpoint {endpoint_kev} keV has no weight")
        mean = float(np.sum(0.5 * (dens[1:] * e[1:] + dens[:-1] * e[:-1]) * np.diff(e)) / total)
        return cls(e, cdf / total, mean)

    def sample(self, u: np.ndarray) -> np.ndarray:
        """Kinetic energies (keV) for uniform numbers ``u`` in [0, 1)."""
        return np.interp(u, self.cdf, self.energy_kev)
