"""TRIM (SRIM-2013, through the PyPI package ``lunasrim``) as the reference for ion ranges.

:class:`RangeSample` is the common currency of score4's own ion transport and of TRIM: the
final position of every ion of a beam sent into a slab, whether it stopped, came back out of
the entrance face or crossed the slab, with the energy it left with.
:func:`srim_range_sample` runs TRIM's Monte Carlo for one case (cached on disk);
:func:`stopping_table_reference` reads SRIM's analytic range table; :func:`summarize`
reduces either side to the numbers TRIM prints.

Geometry of a sample: the beam enters the material at the origin, z = 0, going +z, tilted by
the incidence angle in the x-z plane (direction ``(sin a, 0, cos a)``); the material fills
``0 <= z <= thickness``. TRIM's axes map onto these as TRIM X (depth) -> z, TRIM Y (the plane
of the tilt: lunasrim starts the ion with direction cosines ``(cos a, sin a, 0)``) -> x,
TRIM Z -> y.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import files
from ..errors import ConfigError, Score4Error
from .composition import Composition
from .species import IonSpecies, parse_ion

# SRIM's stopping tables (and so TRIM) cover ions up to uranium and energies up to 2 GeV/amu.
SRIM_MAX_Z = 92
SRIM_MAX_MEV_PER_AMU = 2000.0
# A "semi-infinite" slab is this many times (projected range + 10 longitudinal stragglings) thick.
SEMI_INFINITE_FACTOR = 4.0
_CACHE_FORMAT = 1
_ANGSTROM_MM = 1e-7
_NM_PER_MM = 1e6


@dataclass
class RangeSample:
    """Where the ions of a beam sent into a slab ended (lengths in mm, energies in MeV).

    The beam enters the material at z = 0 going +z (tilted by the incidence angle in the x-z
    plane), x = y = 0; the material fills 0 <= z <= thickness (unbounded for a semi-infinite
    block). Each ion is exactly one of ``stopped``, ``backscattered``, ``transmitted``; for the
    last two ``final_position`` is where it crossed the face.
    """

    final_position: np.ndarray  # (n, 3) mm
    stopped: np.ndarray  # (n,) bool: came to rest inside the material
    backscattered: np.ndarray  # (n,) bool: left through the entrance face (z = 0)
    transmitted: np.ndarray  # (n,) bool: left through the back face (z = thickness)
    exit_energy: np.ndarray  # (n,) MeV kinetic energy when leaving (0 where stopped)
    deposited: np.ndarray  # (n,) MeV deposited in the material (may be nan if unknown)

    def __post_init__(self) -> None:
        self.final_position = np.asarray(self.final_position, dtype=float).reshape(-1, 3)
        n = len(self.final_position)
        for name in ("stopped", "backscattered", "transmitted"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=bool).reshape(n))
        for name in ("exit_energy", "deposited"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=float).reshape(n))

    @property
    def events(self) -> int:
        return len(self.final_position)


def _sem(values: np.ndarray) -> float:
    return float(values.std(ddof=1) / math.sqrt(len(values))) if len(values) > 1 else math.nan


def _fraction(mask: np.ndarray) -> tuple[float, float]:
    n = len(mask)
    if n == 0:
        return math.nan, math.nan
    p = float(mask.mean())
    return p, math.sqrt(p * (1 - p) / n)


def summarize(sample: RangeSample) -> dict:
    """The numbers TRIM prints for a beam, from the ions of ``sample``.

    Keys (nan where no ion qualifies):

    * ``projected_range_nm``: mean depth z of the stopped ions (TRIM's "Ion Average Range");
      ``projected_range_err_nm`` its standard error.
    * ``straggling_nm``: standard deviation of z of the stopped ions, population form
      (TRIM's range "Straggling", sqrt(<z^2> - <z>^2)).
    * ``lateral_nm``: TRIM's "Lateral Straggling" (RANGE.txt, "Ion Lateral Range ...
      Straggling"): the root mean square of an ion's projected lateral displacement from the
      beam axis on one axis of the surface plane, about zero, not about its mean (TRIM tallies
      |y| and y^2 of the stopped ions). At normal incidence both lateral axes are equivalent, and
      here they are pooled: ``sqrt(<(x^2 + y^2) / 2>)``, the radial rms over sqrt(2), which is
      also what SRIM's range table calls lateral straggling. (At oblique incidence TRIM takes
      the axis in the plane of the tilt, whose mean is not zero; this definition is not that.)
      ``straggling_err_nm`` and ``lateral_err_nm`` are the standard errors of a normal
      distribution's standard deviation (sigma / sqrt(2 (n - 1))) and rms (over 2n values).
    * ``backscattered_fraction``, ``transmitted_fraction`` with binomial errors ``*_err``.
    * ``mean_exit_energy_keV``: mean kinetic energy of the transmitted ions (``*_err_keV``).
    * ``mean_deposited_keV``: mean energy deposited per ion (nan if the sample does not know).
    * ``events``, ``stopped``: numbers of ions.
    """
    z = sample.final_position[sample.stopped, 2] * _NM_PER_MM
    xy = sample.final_position[sample.stopped, :2] * _NM_PER_MM
    back, back_err = _fraction(sample.backscattered)
    trans, trans_err = _fraction(sample.transmitted)
    exit_kev = sample.exit_energy[sample.transmitted] * 1e3
    deposited = sample.deposited * 1e3
    nan = math.nan
    straggling = float(z.std()) if len(z) > 1 else nan
    lateral = float(np.sqrt((xy**2).sum(axis=1).mean() / 2)) if len(z) else nan
    return {
        "events": sample.events,
        "stopped": int(sample.stopped.sum()),
        "projected_range_nm": float(z.mean()) if len(z) else nan,
        "projected_range_err_nm": _sem(z),
        "straggling_nm": straggling,
        "straggling_err_nm": straggling / math.sqrt(2 * (len(z) - 1)) if len(z) > 1 else nan,
        "lateral_nm": lateral,
        "lateral_err_nm": lateral / math.sqrt(4 * len(z)) if len(z) else nan,
        "backscattered_fraction": back,
        "backscattered_fraction_err": back_err,
        "transmitted_fraction": trans,
        "transmitted_fraction_err": trans_err,
        "mean_exit_energy_keV": float(exit_kev.mean()) if len(exit_kev) else nan,
        "mean_exit_energy_err_keV": _sem(exit_kev),
        "mean_deposited_keV": float(deposited.mean())
        if len(deposited) and np.isfinite(deposited).all()
        else nan,
    }


# ----------------------------------------------------------------------------- checks
def _lunasrim():
    try:
        import lunasrim
    except ImportError:
        raise Score4Error(
            "SRIM reference: the package lunasrim is not installed; pip install lunasrim"
        ) from None
    return lunasrim


def _species(ion: str | IonSpecies) -> IonSpecies:
    species = ion if isinstance(ion, IonSpecies) else parse_ion(ion, "ion")
    if species.z > SRIM_MAX_Z:
        raise ConfigError(
            f"ion: {species.label} has Z = {species.z}; SRIM/TRIM knows ions up to Z = {SRIM_MAX_Z}"
        )
    return species


def check_srim_energy(species: IonSpecies, energy_mev: float) -> None:
    """Raise :class:`ConfigError` unless 0 < energy <= SRIM's limit of 2 GeV/amu."""
    limit = SRIM_MAX_MEV_PER_AMU * species.mass_amu
    if not (energy_mev > 0 and math.isfinite(energy_mev)):
        raise ConfigError(f"energy: must be > 0, got {energy_mev!r} MeV")
    if energy_mev > limit:
        raise ConfigError(
            f"energy: {energy_mev:g} MeV is above SRIM's validity for {species.label} "
            f"(2 GeV/amu = {limit:g} MeV)"
        )


def _check_angle(angle_deg: float) -> None:
    if not (-89.99 <= angle_deg <= 89.99):
        raise ConfigError(
            f"angle: the incidence angle from the surface normal must be within +-89.99 degrees, "
            f"got {angle_deg!r}"
        )


# ---------------------------------------------------------------------- range table
def stopping_table_reference(
    ion: str | IonSpecies, energy_mev: float, composition: Composition
) -> dict:
    """SRIM's analytic range table (SRModule) at one energy.

    Returns ``projected_range_nm``, ``straggling_nm`` (longitudinal) and ``lateral_nm``
    (SRIM's lateral straggling), plus the electronic and nuclear stopping in keV/um
    (``se_keV_um``, ``sn_keV_um``) and the energy of the table row (``energy_keV``).
    """
    lunasrim = _lunasrim()
    species = _species(ion)
    check_srim_energy(species, energy_mev)
    kev = energy_mev * 1e3
    rows = lunasrim.stopping_table(
        species.symbol,
        composition.lunasrim_target(),
        emin=kev,
        emax=kev,
        units="keV/um",
        density=composition.density,
        mass=species.mass_amu,
    )
    e, se, sn, rp, lon, lat = rows[-1]
    return {
        "energy_keV": float(e),
        "se_keV_um": float(se),
        "sn_keV_um": float(sn),
        "projected_range_nm": float(rp) / 10,
        "straggling_nm": float(lon) / 10,
        "lateral_nm": float(lat) / 10,
    }


def semi_infinite_thickness_mm(
    ion: str | IonSpecies, energy_mev: float, composition: Composition
) -> float:
    """A slab thickness no ion crosses: 4 x (projected range + 10 longitudinal stragglings)."""
    ref = stopping_table_reference(ion, energy_mev, composition)
    return (
        SEMI_INFINITE_FACTOR * (ref["projected_range_nm"] + 10 * ref["straggling_nm"]) / _NM_PER_MM
    )


# ------------------------------------------------------------------------ TRIM runs
def cache_dir() -> Path:
    """Where TRIM results are kept: ``$XDG_CACHE_HOME/score4/srim`` (``~/.cache/score4/srim``)."""
    return files.cache_dir("srim")


def _cache_key(inputs: dict) -> str:
    text = json.dumps(inputs, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def srim_range_sample(
    ion: str | IonSpecies,
    energy_mev: float,
    composition: Composition,
    ions: int,
    seed: int,
    thickness_mm: float | None = None,
    angle_deg: float = 0.0,
    *,
    cache: bool = True,
    progress: Callable[[int, int], None] | None = None,
) -> RangeSample:
    """``ions`` TRIM ions of ``energy_mev`` into ``composition`` (lunasrim, SRIM-2013).

    Parameters
    ----------
    ion
        ``"Pb206"``, ``"alpha"``, ... (mass from :func:`~score4.ions.species.atomic_mass_amu`).
    energy_mev
        Kinetic energy in MeV.
    composition
        Target elements and density (the same density as the Geant4 material, so nm agree).
    ions, seed
        Number of ions (>= 1) and TRIM's random seed (0 <= seed < 2147483563; 0 is TRIM's
        default seed, the same as 16381).
    thickness_mm
        Slab thickness; ``None`` for a semi-infinite block (a slab of
        :func:`semi_infinite_thickness_mm`).
    angle_deg
        Incidence angle from the surface normal, degrees (lunasrim's convention: TRIM's first
        direction is ``(cos a, sin a, 0)`` with X the depth), tilted towards +x here.
    cache
        Keep the result in :func:`cache_dir`, keyed by every input and the lunasrim version.
    progress
        ``progress(done, total)`` is called as ions finish (not for cached results).

    Returns
    -------
    RangeSample
        Stopped ions at TRIM's RANGE_3D positions; transmitted and backscattered ions (TRANSMIT,
        BACKSCAT) where their last straight flight crossed the face, with their energies.
        ``deposited`` is the energy the ion did not carry out (TRIM's quick calculation follows
        no recoils, so energy carried off by sputtered target atoms is not subtracted).
    """
    lunasrim = _lunasrim()
    species = _species(ion)
    check_srim_energy(species, energy_mev)
    _check_angle(angle_deg)
    if isinstance(ions, bool) or int(ions) != ions or ions < 1:
        raise ConfigError(f"ions: the number of ions must be an integer >= 1, got {ions!r}")
    if isinstance(seed, bool) or int(seed) != seed or not 0 <= seed < 2147483563:
        raise ConfigError(f"seed: TRIM's seed must be an integer in [0, 2147483562], got {seed!r}")
    semi_infinite = thickness_mm is None
    if thickness_mm is None:
        thickness_mm = semi_infinite_thickness_mm(species, energy_mev, composition)
    elif not (thickness_mm > 0 and math.isfinite(thickness_mm)):
        raise ConfigError(f"thickness: must be > 0, got {thickness_mm!r} mm")
    thickness_nm = float(thickness_mm) * _NM_PER_MM
    inputs = {
        "format": _CACHE_FORMAT,
        "lunasrim": lunasrim.__version__,
        "ion": [species.z, species.a, species.mass_amu],
        "energy_mev": float(energy_mev),
        "target": [list(a) for a in composition.atoms],
        "density": composition.density,
        "ions": int(ions),
        "seed": int(seed),
        "thickness_nm": thickness_nm,
        "angle_deg": float(angle_deg),
    }
    path = cache_dir() / f"{_cache_key(inputs)}.npz"
    if cache and path.is_file():
        try:
            with np.load(path) as stored:
                return RangeSample(**{k: stored[k] for k in RangeSample.__dataclass_fields__})
        except (OSError, ValueError, KeyError):
            pass  # a damaged cache file is recomputed
    sample = _run_trim(
        lunasrim,
        species,
        energy_mev,
        composition,
        int(ions),
        int(seed),
        thickness_nm,
        angle_deg,
        progress,
    )
    if semi_infinite and sample.transmitted.any():
        raise Score4Error(
            f"SRIM reference: {int(sample.transmitted.sum())} ions crossed the "
            f"{thickness_nm:g} nm slab meant to be semi-infinite"
        )
    if cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.stem}.{os.getpid()}.partial.npz")
        np.savez(tmp, **{k: getattr(sample, k) for k in RangeSample.__dataclass_fields__})
        os.replace(tmp, path)
    return sample


def _run_trim(
    lunasrim, species, energy_mev, composition, ions, seed, thickness_nm, angle_deg, progress
) -> RangeSample:
    workdir = tempfile.mkdtemp(prefix="score4_trim_")
    try:
        callback = None
        if progress is not None:
            step = max(1, ions // 20)

            def callback(number, _engine):
                if number % step == 0 or number == ions:
                    progress(number, ions)

        result = lunasrim.trim(
            species.symbol,
            composition.lunasrim_target(),
            energy=energy_mev * 1e3,
            thickness=thickness_nm,
            unit="nm",
            ions=ions,
            angle=angle_deg,
            seed=seed,
            directory=workdir,
            density=composition.density,
            mass=species.mass_amu,
            progress=callback,
        )
        return _sample_from_results(result, ions, energy_mev, thickness_nm * 10)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


_NEGATIVE_GAP = re.compile(r"-\s+(?=[\d.])")


def _read_exit_file(path: Path) -> np.ndarray:
    """Rows (ion, Z, energy eV, x, y, z Angstrom, cos x, cos y, cos z) of TRANSMIT/BACKSCAT.txt.

    TRIM's Visual Basic format writes a negative depth as ``-  4037550E-05`` (sign, blanks,
    mantissa), which lunasrim 1.0.0's reader drops (every backscattered ion); here the sign
    is joined to its number.
    """
    rows = []
    if not path.is_file():
        return np.zeros((0, 9))
    for line in path.read_bytes().decode("latin-1").splitlines():
        if len(line) > 2 and line[0] in "TB" and line[1] == " ":
            fields = _NEGATIVE_GAP.sub("-", line[1:]).split()
            if len(fields) == 9:
                rows.append([float(f) for f in fields])
    return np.array(rows, dtype=float).reshape(-1, 9)


def _sample_from_results(result, ions: int, energy_mev: float, width_a: float) -> RangeSample:
    """RangeSample from lunasrim's RANGE_3D, TRANSMIT and BACKSCAT (Angstrom, eV)."""
    position = np.full((ions, 3), np.nan)
    stopped = np.zeros(ions, dtype=bool)
    back = np.zeros(ions, dtype=bool)
    trans = np.zeros(ions, dtype=bool)
    exit_energy = np.zeros(ions)

    r3 = result.range3d
    k = np.asarray(r3.ion_number, dtype=int) - 1
    depth, lat_y, lat_z = (np.asarray(c, dtype=float) for c in r3.positions)
    position[k] = np.column_stack([lat_y, lat_z, depth]) * _ANGSTROM_MM
    stopped[k] = True
    for name, mask, face in (("TRANSMIT.txt", trans, width_a), ("BACKSCAT.txt", back, 0.0)):
        rows = _read_exit_file(Path(result.directory) / name)
        if not len(rows):
            continue
        k = rows[:, 0].astype(int) - 1
        x, y, z, cx, cy, cz = rows[:, 3:9].T
        # TRIM reports the end of the flight that left the slab; go back along it to the face
        t = np.where(cx != 0, (x - face) / np.where(cx == 0, 1, cx), 0.0)
        position[k] = np.column_stack([y - t * cy, z - t * cz, np.full(len(k), face)]) * 1e-7
        mask[k] = True
        exit_energy[k] = rows[:, 2] * 1e-6
    counts = stopped.astype(int) + back + trans
    if not (counts == 1).all():
        raise Score4Error(
            f"SRIM reference: TRIM's files account for {int((counts == 1).sum())} of {ions} ions "
            f"exactly once (stopped {int(stopped.sum())}, transmitted {int(trans.sum())}, "
            f"backscattered {int(back.sum())})"
        )
    return RangeSample(
        final_position=position,
        stopped=stopped,
        backscattered=back,
        transmitted=trans,
        exit_energy=exit_energy,
        deposited=energy_mev - exit_energy,
    )
