"""Emitters: which particles start at each decay vertex, with which energy and direction.

* Directions: isotropic (4 pi); uniform into the half-space ``inward`` (into the material,
  against the outward normal) or ``outward``; cosine-weighted (Lambert) ``cosine_inward`` /
  ``cosine_outward`` about the normal.
* Energies: :class:`Monoenergetic` or :class:`EnergySpectrum` (piecewise-linear density or
  histogram, sampled by exact inversion; from arrays or a text file with ``# unit: keV``).
* :class:`ParticleEmitter` (one particle per event), :class:`Po210Emitter` (the 5.30433 MeV
  alpha and its Pb-206 recoil, back to back, two primaries of the same event) and
  :class:`NuclideEmitter` (the ion itself at rest, for Geant4 radioactive decay).
* :func:`make_primaries` turns vertices + an emitter into :class:`Primaries`.

Po-210 kinematics
-----------------
Two-body decay at rest, relativistic momentum balance: ``p^2 = T_a (T_a + 2 m_a)`` and
``T_Pb = p^2 / (sqrt(p^2 + M^2) + M)`` (the cancellation-free form of ``sqrt(p^2 + M^2) - M``).
Masses: alpha particle ``m_a = 3727.3794066 MeV`` (CODATA 2018); Pb-206 nucleus
``M = 205.9744651 u`` (AME2020 atomic mass) ``- 82 m_e + B_e`` with ``u = 931.49410242 MeV``,
``m_e = 0.51099895 MeV`` and the total electron binding energy
``B_e = 14.4381 Z^2.39 + 1.55468e-6 Z^5.35 eV`` (Lunney, Pearson, Thibault 2003), 0.568 MeV.
This gives ``T_Pb = 0.103144 MeV`` (Q = 5.40747 MeV).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol, cast, get_args

import numpy as np
from numpy.typing import ArrayLike

from score4.inputs.units import parse_quantity

from ..elements import ELEMENTS, nuclide_za, split_nuclide
from ..errors import ConfigError
from .primaries import Primaries
from .sampling import Histogram, PiecewiseLinear, orthonormal_basis, read_table

__all__ = [
    "ALPHA_MASS",
    "PB206_MASS",
    "PO210_ALPHA_ENERGY",
    "PO210_RECOIL_ENERGY",
    "EnergySpectrum",
    "Monoenergetic",
    "NuclideEmitter",
    "ParticleEmitter",
    "Po210Emitter",
    "cosine_directions",
    "hemisphere_directions",
    "isotropic_directions",
    "make_primaries",
    "normalise_nuclide",
    "normalise_particle",
    "recoil_energy",
    "sample_directions",
]

DirectionKind = Literal[
    "isotropic", "inward", "outward", "cosine_inward", "cosine_outward", "normal"
]
DIRECTIONS: tuple[str, ...] = get_args(DirectionKind)

# --------------------------------------------------------------------------------------------
# Particle and nuclide names
# --------------------------------------------------------------------------------------------


# Geant4 particle names accepted as they are (ions are written element + mass number)
PARTICLES: frozenset[str] = frozenset(
    (
        "gamma",
        "e-",
        "e+",
        "mu-",
        "mu+",
        "alpha",
        "proton",
        "neutron",
        "deuteron",
        "triton",
        "He3",
        "geantino",
        "chargedgeantino",
        "opticalphoton",
        "pi+",
        "pi-",
        "pi0",
        "kaon+",
        "kaon-",
        "kaon0L",
        "anti_proton",
        "anti_neutron",
        "nu_e",
        "anti_nu_e",
        "nu_mu",
        "anti_nu_mu",
    )
)


def normalise_nuclide(name: str) -> str:
    """``"Po-210"``, ``"po210"``, ``"210Po"`` -> ``"Po210"`` (Geant4 ion name, ground state).

    Raises
    ------
    ConfigError
        Unknown element symbol, or a mass number below the atomic number or above 300.
    """
    parts = split_nuclide(str(name))
    if parts is None:
        raise ConfigError(
            f"nuclide: cannot read {name!r}; write element symbol + mass number, e.g. 'Pb210' or "
            "'Po-210'"
        )
    symbol, mass, _ = parts
    z, a = nuclide_za(symbol, mass, name, "nuclide")
    return f"{ELEMENTS[z - 1]}{a}"


def normalise_particle(name: str) -> str:
    """A Geant4 particle name (``"alpha"``, ``"e-"``) as is, or a normalised ion name."""
    name = str(name).strip()
    if name in PARTICLES:
        return name
    if split_nuclide(name) is not None:
        return normalise_nuclide(name)
    raise ConfigError(
        f"particle: unknown name {name!r}; use a Geant4 particle ({', '.join(sorted(PARTICLES))}) "
        "or an ion written as element + mass number (e.g. 'Pb206')"
    )


# --------------------------------------------------------------------------------------------
# Directions
# --------------------------------------------------------------------------------------------


def isotropic_directions(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) unit vectors uniform on the sphere (cos(theta) uniform in [-1, 1])."""
    cos = 2.0 * rng.random(n) - 1.0
    phi = 2.0 * np.pi * rng.random(n)
    sin = np.sqrt(np.maximum(1.0 - cos * cos, 0.0))
    return np.stack([sin * np.cos(phi), sin * np.sin(phi), cos], axis=1)


def _about_axis(rng: np.random.Generator, axis: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """Unit vectors at polar cosine ``cos`` about unit ``axis`` (k, 3), azimuth uniform."""
    e1, e2 = orthonormal_basis(axis)
    phi = 2.0 * np.pi * rng.random(len(axis))
    sin = np.sqrt(np.maximum(1.0 - cos * cos, 0.0))
    u = cos[:, None] * axis + (sin * np.cos(phi))[:, None] * e1 + (sin * np.sin(phi))[:, None] * e2
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _axis(normals: ArrayLike, side: str) -> np.ndarray:
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    if side not in ("inward", "outward"):
        raise ConfigError(f"side: got {side!r}; use 'inward' (into the material) or 'outward'")
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    if not (norm > 0).all():
        raise ConfigError("normals: every normal must be a non-zero vector")
    return (n / norm) * (-1.0 if side == "inward" else 1.0)


def hemisphere_directions(
    rng: np.random.Generator, normals: ArrayLike, side: str = "inward"
) -> np.ndarray:
    """Uniform directions in the half-space ``inward`` (against the normal) or ``outward``."""
    axis = _axis(normals, side)
    return _about_axis(rng, axis, rng.random(len(axis)))


def cosine_directions(
    rng: np.random.Generator, normals: ArrayLike, side: str = "inward"
) -> np.ndarray:
    """Lambert (cosine-weighted) directions about the inward or outward normal: the cosine to
    the axis has density ``2 c`` on [0, 1]."""
    axis = _axis(normals, side)
    return _about_axis(rng, axis, np.sqrt(rng.random(len(axis))))


def sample_directions(
    rng: np.random.Generator, kind: DirectionKind, n: int, normals: ArrayLike | None = None
) -> np.ndarray:
    """``n`` directions of the given kind; every kind but ``isotropic`` needs ``normals``.

    ``normal`` is not random: every direction is the inward normal itself.
    """
    if kind == "isotropic":
        return isotropic_directions(rng, n)
    if kind not in DIRECTIONS:
        raise ConfigError(f"direction: got {kind!r}; use one of: {', '.join(DIRECTIONS)}")
    if normals is None:
        raise ConfigError(f"direction: {kind!r} needs the surface normal of every vertex")
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    if len(normals) != n:
        raise ConfigError(f"normals: got {len(normals)} normals for {n} vertices")
    if kind == "normal":  # a pencil beam along the inward normal
        return _axis(normals, "inward")
    if kind.startswith("cosine_"):
        return cosine_directions(rng, normals, kind.removeprefix("cosine_"))
    return hemisphere_directions(rng, normals, kind)


# --------------------------------------------------------------------------------------------
# Energies
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Monoenergetic:
    """A single kinetic energy in MeV (> 0)."""

    energy: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.energy) and self.energy > 0):
            raise ConfigError(
                f"energy: got {float(self.energy):g} MeV; must be a finite energy > 0"
            )

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return np.full(n, float(self.energy))


class EnergySpectrum:
    """An energy spectrum given as a table of rows ``(E_i, w_i)``, energies in MeV.

    Parameters
    ----------
    energies
        (k,) strictly increasing energies (MeV, >= 0).
    weights
        (k,) non-negative weights, not all zero.
    kind
        ``"linear"``: ``w_i`` is the density at ``E_i``, linear in between (exact inversion of
        the piecewise-quadratic CDF). ``"histogram"``: ``w_i`` is the content of the bin
        ``[E_i, E_{i+1})``, flat inside it; the last row only closes the last bin and its
        weight must be 0.
    """

    def __init__(
        self,
        energies: ArrayLike,
        weights: ArrayLike,
        kind: Literal["linear", "histogram"] = "linear",
    ) -> None:
        e = np.asarray(energies, dtype=float).ravel()
        w = np.asarray(weights, dtype=float).ravel()
        self.kind = kind
        if kind == "linear":
            self._law: PiecewiseLinear | Histogram = PiecewiseLinear(
                e, w, what="energy spectrum", xname="energy"
            )
        elif kind == "histogram":
            if len(w) and w[-1] != 0:
                raise ConfigError(
                    f"energy spectrum: the last row ({e[-1]:g} MeV) closes the last histogram bin; "
                    f"its weight must be 0, got {w[-1]:g}"
                )
            self._law = Histogram(e, w[:-1], what="energy spectrum", xname="energy")
        else:
            raise ConfigError(f"kind: got {kind!r}; use 'linear' or 'histogram'")

    @classmethod
    def from_file(
        cls,
        path: str | Path,
        kind: Literal["linear", "histogram"] = "linear",
        unit: str | None = None,
    ) -> EnergySpectrum:
        """Read ``energy weight`` rows; the unit comes from a ``# unit: keV`` header or ``unit``."""
        energies, weights = read_table(
            path, "energy", unit=unit, what="energy spectrum", xname="energy"
        )
        return cls(energies, weights, kind)

    def pdf(self, e: ArrayLike) -> np.ndarray:
        return self._law.pdf(e)

    def cdf(self, e: ArrayLike) -> np.ndarray:
        return self._law.cdf(e)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self._law.sample(rng, n)


# --------------------------------------------------------------------------------------------
# Emitters
# --------------------------------------------------------------------------------------------


class Emitter(Protocol):
    """What starts at a vertex: ``emit`` returns one (particle, energy, direction) per primary."""

    def emit(
        self, rng: np.random.Generator, n: int, normals: np.ndarray | None
    ) -> list[tuple[str, np.ndarray, np.ndarray]]: ...


class VariableEmitter(Protocol):
    """An emitter with a variable number of primaries per event (see ``make_primaries``)."""

    def emit_rows(self, rng: np.random.Generator, n: int, normals: np.ndarray | None) -> Any: ...


def _check_direction(direction: str) -> DirectionKind:
    if direction not in DIRECTIONS:
        raise ConfigError(f"direction: got {direction!r}; use one of: {', '.join(DIRECTIONS)}")
    return cast(DirectionKind, direction)


class ParticleEmitter:
    """One particle per event.

    Parameters
    ----------
    particle
        Geant4 particle name or ion name (normalised, e.g. ``"Po-210"`` -> ``"Po210"``).
    energy
        Kinetic energy in MeV (or a string such as ``"5.3 MeV"``), or a
        :class:`Monoenergetic` / :class:`EnergySpectrum`.
    direction
        One of ``isotropic``, ``inward``, ``outward``, ``cosine_inward``, ``cosine_outward``.
    """

    def __init__(
        self,
        particle: str,
        energy: float | str | Monoenergetic | EnergySpectrum,
        direction: DirectionKind = "isotropic",
    ) -> None:
        self.particle = normalise_particle(particle)
        if isinstance(energy, str):
            energy = parse_quantity(energy, "energy", "energy")
        self.energy = (
            energy
            if isinstance(energy, (Monoenergetic, EnergySpectrum))
            else Monoenergetic(float(energy))
        )
        self.direction = _check_direction(direction)

    def emit(
        self, rng: np.random.Generator, n: int, normals: np.ndarray | None
    ) -> list[tuple[str, np.ndarray, np.ndarray]]:
        direction = sample_directions(rng, self.direction, n, normals)
        return [(self.particle, self.energy.sample(rng, n), direction)]


ALPHA_MASS = 3727.3794066  # MeV, alpha particle (CODATA 2018)
_U, _ME = 931.49410242, 0.51099895  # MeV: atomic mass unit, electron mass (CODATA 2018)
_PB_BINDING = (14.4381 * 82**2.39 + 1.55468e-6 * 82**5.35) * 1e-6  # MeV, all 82 electrons
PB206_MASS = 205.9744651 * _U - 82 * _ME + _PB_BINDING  # MeV, bare Pb-206 nucleus
PO210_ALPHA_ENERGY = 5.30433  # MeV


def recoil_energy(
    alpha_energy: float, alpha_mass: float = ALPHA_MASS, recoil_mass: float = PB206_MASS
) -> float:
    """Kinetic energy (MeV) of the recoil balancing the momentum of an alpha of ``alpha_energy``."""
    p2 = alpha_energy * (alpha_energy + 2.0 * alpha_mass)
    return p2 / (np.sqrt(p2 + recoil_mass**2) + recoil_mass)


PO210_RECOIL_ENERGY = recoil_energy(PO210_ALPHA_ENERGY)


class Po210Emitter:
    """Po-210 decay: an alpha of 5.30433 MeV and the Pb-206 recoil, back to back.

    Parameters
    ----------
    direction
        Direction law of the alpha (the recoil goes the opposite way).
    """

    def __init__(self, direction: DirectionKind = "isotropic") -> None:
        self.direction = _check_direction(direction)

    def emit(
        self, rng: np.random.Generator, n: int, normals: np.ndarray | None
    ) -> list[tuple[str, np.ndarray, np.ndarray]]:
        alpha = sample_directions(rng, self.direction, n, normals)
        return [
            ("alpha", np.full(n, PO210_ALPHA_ENERGY), alpha),
            ("Pb206", np.full(n, PO210_RECOIL_ENERGY), -alpha),
        ]


class NuclideEmitter:
    """The nuclide itself at rest (energy 0); Geant4 radioactive decay does the rest.

    The simulation layer must check that the radioactive-decay data are installed. The
    direction is +z (unused for a particle at rest, but every primary needs one).
    """

    def __init__(self, nuclide: str) -> None:
        self.nuclide = normalise_nuclide(nuclide)

    def emit(
        self, rng: np.random.Generator, n: int, normals: np.ndarray | None
    ) -> list[tuple[str, np.ndarray, np.ndarray]]:
        return [(self.nuclide, np.zeros(n), np.tile([0.0, 0.0, 1.0], (n, 1)))]


def make_primaries(
    emitter: Emitter | VariableEmitter,
    rng: np.random.Generator,
    positions: ArrayLike,
    normals: ArrayLike | None = None,
    *,
    depth: ArrayLike | None = None,
    facet: ArrayLike | None = None,
    patch: ArrayLike | None = None,
    face: ArrayLike | None = None,
) -> Primaries:
    """One event per vertex: the emitter's primaries, all starting at that vertex.

    Parameters
    ----------
    emitter
        :class:`ParticleEmitter`, :class:`Po210Emitter`, :class:`NuclideEmitter` or any
        object with the same ``emit`` method; or an emitter with ``emit_rows`` (a variable
        number of primaries per event, :class:`score4.source.decay_source.DecayEmitter`),
        whose extra columns (``nuclide``, ``time``) are kept too.
    positions
        (n, 3) vertex positions in mm.
    normals
        (n, 3) outward surface normals (needed by every direction law but ``isotropic``).
    depth, facet, patch, face
        Optional (n,) per-vertex columns, copied to every primary of the event as extra
        columns ``depth`` (mm), ``facet``, ``patch`` and ``face`` (index of the volume's face).
    """
    pos = np.asarray(positions, dtype=float).reshape(-1, 3)
    n = len(pos)
    if hasattr(emitter, "emit_rows"):  # a variable number of primaries per event (decays)
        return _variable_rows(
            emitter, rng, pos, normals, depth=depth, facet=facet, patch=patch, face=face
        )
    parts = emitter.emit(
        rng, n, None if normals is None else np.asarray(normals, dtype=float).reshape(-1, 3)
    )
    k = len(parts)  # rows per event, event-major: row = event * k + j
    extra = {}
    for name, col in (("depth", depth), ("facet", facet), ("patch", patch), ("face", face)):
        if col is not None:
            col = np.asarray(col)
            if col.shape != (n,):
                raise ConfigError(
                    f"{name}: need one value per vertex ({n},), got shape {col.shape}"
                )
            extra[name] = np.repeat(col, k)
    return Primaries(
        event=np.repeat(np.arange(n), k),
        particle=np.stack([np.full(n, p[0]) for p in parts], axis=1).ravel(),
        energy=np.stack([p[1] for p in parts], axis=1).ravel(),
        position=np.repeat(pos, k, axis=0),
        direction=np.stack([p[2] for p in parts], axis=1).reshape(-1, 3),
        extra=extra,
    )


def _event_columns(n: int, **columns: ArrayLike | None) -> dict[str, np.ndarray]:
    out = {}
    for name, col in columns.items():
        if col is not None:
            col = np.asarray(col)
            if col.shape != (n,):
                raise ConfigError(
                    f"{name}: need one value per vertex ({n},), got shape {col.shape}"
                )
            out[name] = col
    return out


def _variable_rows(emitter, rng, pos, normals, **columns) -> Primaries:
    n = len(pos)
    per_event = _event_columns(n, **columns)
    if normals is not None:
        normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    rows = emitter.emit_rows(rng, n, normals)
    at = rows.event if getattr(rows, "vertex", None) is None else rows.vertex
    extra = {**{k: v[at] for k, v in per_event.items()}, **rows.extra}
    if at is not rows.event and normals is not None:
        # per-atom histories: a decay moved by a recoil gets its depth below the surface plane
        # of its atom's deposit, along this normal (score4.sim.implantation)
        extra.update({f"normal_{a}": normals[at, k] for k, a in enumerate("xyz")})
    return Primaries(
        event=rows.event,
        particle=rows.particle,
        energy=rows.energy,
        position=pos[at],
        direction=rows.direction,
        extra=extra,
    )
