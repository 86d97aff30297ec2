"""Heavy ions moved along TRIM trajectories through the real Geant4 geometry.

Geant4 ranges slow heavy ions badly (a 103 keV Pb-206 recoil stops ~6x too shallow in Si, with
no straggling; ``benchmarks/bench_ion_setups.py`` measures every set-up tried). Primaries that
are ions with Z > 2 below ``physics.trim_max_energy`` are therefore not given to Geant4: after
Geant4 has tracked a chunk's other primaries, each such ion follows a TRIM history from
:mod:`score4.ions.trim_library`, continued from its energy and direction, walked through the
geometry with a Geant4 navigator of its own:

* the energy lost along each piece of the polyline is deposited in the volume that piece lies
  in (split at a boundary in proportion to length), so the event's deposits add up to the ion's
  energy minus what it carries out of the world;
* at a boundary into another volume of matter the ion goes on with a new continuation for that
  volume's material (its energy and direction kept), so it may cross from a patch into its
  neighbour or from a rough layer into the target below;
* in vacuum it flies straight until it meets matter again (a recoil leaving a spike may enter the
  next one) or leaves the world.

Python runs per heavy ion, not per Geant4 step; pieces that lie inside the current volume's
safety sphere are summed in numpy without asking the navigator.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ..errors import Score4Error
from ..ions.composition import Composition
from ..ions.trim_library import TrajectoryLibrary, rotation_from_x, trim_library

_ION = re.compile(r"^([A-Z][a-z]?)-?(\d{1,3})$")
#: Materials thinner than this (g/cm3) are vacuum for a heavy ion: it crosses them in a line.
VACUUM_DENSITY = 1e-5
_MAX_CROSSINGS = 10_000
_FAR = 1e90


def heavy_ion_z(g4, name: str) -> int:
    """Z of an ion name such as ``Pb206`` if it is an ion heavier than helium, else 0."""
    match = _ION.match(name)
    if not match:
        return 0
    z = int(g4.G4NistManager.Instance().GetZ(match.group(1)))
    return z if z > 2 else 0


@dataclass
class IonFate:
    """Where a replayed ion ended and what it left behind."""

    position: np.ndarray  # (3,) mm: where it stopped or left the world
    escaped_energy: float  # MeV carried out of the world (0 when it stopped)
    deposits: dict[int, float] = field(default_factory=dict)  # scoring index -> MeV
    lengths: dict[int, float] = field(default_factory=dict)  # scoring index -> mm in matter
    crossings: int = 0  # boundaries crossed


class HeavyIonTransport:
    """Replays heavy ions in a built world (see the module docstring)."""

    def __init__(
        self,
        g4,
        world,
        scoring: dict[str, list],
        histories: int = 1000,
        library_seed: int = 1,
    ) -> None:
        self.g4 = g4
        self.nav = g4.G4Navigator()
        self.nav.SetWorldVolume(world)
        self.index = {str(lv.GetName()): k for k, lvs in enumerate(scoring.values()) for lv in lvs}
        self.histories = histories
        self.library_seed = library_seed
        self._libraries: dict[tuple[str, str], TrajectoryLibrary] = {}
        self._energy_needed: dict[str, float] = {}
        self._compositions: dict[str, Composition] = {}

    # -- libraries -------------------------------------------------------------------------------

    def need(self, ion: str, energy: float) -> None:
        """Announce the largest energy (MeV) an ion will have, so libraries are built for it."""
        self._energy_needed[ion] = max(self._energy_needed.get(ion, 0.0), energy)

    def library(self, particle, ion: str, material) -> TrajectoryLibrary:
        name = str(material.GetName())
        energy = self._energy_needed.get(ion, 0.0)
        key = (ion, name)
        lib = self._libraries.get(key)
        if lib is None or lib.energy < energy:
            comp = self._compositions.get(name)
            if comp is None:
                comp = self._compositions[name] = Composition.from_g4_material(material)
            mass_amu = float(particle.GetPDGMass()) / float(self.g4.amu_c2)
            lib = trim_library(
                ion,
                int(round(particle.GetPDGCharge())),
                mass_amu,
                energy,
                comp,
                n=self.histories,
                seed=self.library_seed,
            )
            self._libraries[key] = lib
        return lib

    # -- transport -------------------------------------------------------------------------------

    def _vec(self, v) -> object:
        return self.g4.G4ThreeVector(float(v[0]), float(v[1]), float(v[2]))

    def _locate(self, point, direction, relative: bool):
        return self.nav.LocateGlobalPointAndSetup(
            self._vec(point), self._vec(direction), relative, False
        )

    def transport(
        self,
        particle,
        ion: str,
        energy: float,
        position,
        direction,
        rng: np.random.Generator,
    ) -> IonFate:
        """Move one ion (``energy`` MeV from ``position`` mm along unit ``direction``)."""
        self.need(ion, energy)
        pos = np.asarray(position, dtype=float).copy()
        d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
        fate = IonFate(pos, 0.0)
        pv = self._locate(pos, d, relative=False)
        e = float(energy)
        while e > 0:
            if fate.crossings > _MAX_CROSSINGS:
                raise Score4Error(
                    f"{ion} of {energy * 1e3:.6g} keV from {tuple(np.round(position, 9))} mm: "
                    f"crossed more than {_MAX_CROSSINGS} boundaries (a geometry fault?)"
                )
            if pv is None:  # left the world
                fate.escaped_energy = e
                break
            lv = pv.GetLogicalVolume()
            material = lv.GetMaterial()
            if float(material.GetDensity()) < VACUUM_DENSITY * self.g4.g / self.g4.cm3:
                step = self.nav.ComputeStep(self._vec(pos), self._vec(d), _FAR, 0.0)
                if step >= _FAR:
                    fate.escaped_energy = e
                    break
                pos = pos + step * d
                self.nav.SetGeometricallyLimitedStep()
                pv = self._locate(pos, d, relative=True)
                fate.crossings += 1
                continue
            volume = self.index.get(str(lv.GetName()))
            lib = self.library(particle, ion, material)
            rel, energies, left = lib.continuation(e, rng)
            points = pos + rel @ rotation_from_x(d).T
            end = self._walk(points, energies, volume, fate)
            if end is None:  # the history ended inside this volume
                pos = points[-1]
                e = float(energies[-1])
                if not left:
                    if e > 0:
                        _add(fate.deposits, volume, e)
                    e = 0.0
                    break
                # TRIM's layer ended (rare): go on from its last point in the same direction
                d = points[-1] - points[-2]
                d /= np.linalg.norm(d)
                pv = self._locate(pos, d, relative=False)
                continue
            pos, e, d = end
            self.nav.SetGeometricallyLimitedStep()
            pv = self._locate(pos, d, relative=True)
            fate.crossings += 1
        fate.position = pos
        return fate

    def _walk(
        self, points: np.ndarray, energies: np.ndarray, volume: int | None, fate: IonFate
    ) -> tuple[np.ndarray, float, np.ndarray] | None:
        """Deposit along ``points`` while they stay in the located volume.

        Returns ``(exit point, energy there, direction)`` at the first boundary, or None when the
        polyline ends inside.
        """
        g4 = self.g4
        nav = self.nav
        m = len(points)
        i = 0
        centre = points[0]
        safety = nav.ComputeSafety(self._vec(centre), _FAR, True)
        while i < m - 1:
            # pieces whose ends lie in the safety sphere about `centre` are inside the volume
            dist = np.linalg.norm(points[i + 1 :] - centre, axis=1)
            outside = np.flatnonzero(dist >= safety)
            j = i + (int(outside[0]) if len(outside) else m - 1 - i)
            if j > i:
                _add(fate.deposits, volume, float(energies[i] - energies[j]))
                _add(
                    fate.lengths,
                    volume,
                    float(np.linalg.norm(np.diff(points[i : j + 1], axis=0), axis=1).sum()),
                )
                i = j
                if i >= m - 1:
                    return None
            a, b = points[i], points[i + 1]
            length = float(np.linalg.norm(b - a))
            if length == 0.0:
                i += 1
                continue
            u = (b - a) / length
            pa = g4.G4ThreeVector(*a)
            nav.LocateGlobalPointWithinVolume(pa)
            step = nav.ComputeStep(pa, g4.G4ThreeVector(*u), length, 0.0)
            if step >= length:
                _add(fate.deposits, volume, float(energies[i] - energies[i + 1]))
                _add(fate.lengths, volume, length)
                i += 1
                centre = b
                nav.LocateGlobalPointWithinVolume(g4.G4ThreeVector(*b))
                safety = nav.ComputeSafety(g4.G4ThreeVector(*b), _FAR, True)
                continue
            lost = float(energies[i] - energies[i + 1]) * step / length
            _add(fate.deposits, volume, lost)
            _add(fate.lengths, volume, step)
            return a + step * u, float(energies[i]) - lost, u
        return None


def _add(table: dict[int, float], key: int | None, value: float) -> None:
    if key is not None and value:
        table[key] = table.get(key, 0.0) + value
