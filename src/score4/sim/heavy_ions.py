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

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import Score4Error
from ..ions.composition import Composition
from ..ions.trim_library import TrajectoryLibrary, rotation_from_x, trim_library
from ..source.primaries import Primaries

#: Materials thinner than this (g/cm3) are vacuum for a heavy ion: it crosses them in a line.
VACUUM_DENSITY = 1e-5
_MAX_CROSSINGS = 10_000
_FAR = 1e90


def heavy_ion_z(particle) -> int:
    """Z of a Geant4 particle definition if it is a nucleus heavier than helium, else 0."""
    z = int(particle.GetAtomicNumber())
    return z if particle.GetParticleType() == "nucleus" and z > 2 else 0


def trim_mask(
    primaries: Primaries,
    definition: Callable[[str], Any],
    heavy_ions: str = "trim",
    alphas: str = "geant4",
    max_energy: float = 1.0,
) -> np.ndarray:
    """Rows of ``primaries`` that follow TRIM trajectories instead of Geant4.

    Ions heavier than helium up to ``max_energy`` (MeV) with ``heavy_ions="trim"``, and alphas
    of any energy with ``alphas="trim"`` (the settings ``physics.heavy_ions``,
    ``physics.alphas`` and ``physics.trim_max_energy`` of a run configuration).
    ``definition(name)`` gives the G4ParticleDefinition of a particle name.
    """
    mask = np.zeros(len(primaries), dtype=bool)
    for name in np.unique(primaries.particle):
        rows = primaries.particle == name
        if name == "alpha" and alphas == "trim":
            mask |= rows
        elif heavy_ions == "trim" and heavy_ion_z(definition(str(name))):
            mask |= rows & (primaries.energy <= max_energy)
    return mask


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
        self._libraries: dict[tuple[str, str, float], TrajectoryLibrary] = {}
        self._energies: dict[str, set[float]] = {}
        self._compositions: dict[str, Composition] = {}

    # -- libraries -------------------------------------------------------------------------------

    def need(self, ion: str, energy: float) -> None:
        """Announce an energy (MeV) an ion starts with: it gets a library of exactly that energy.

        A history continued from its start is exact; one continued from inside (re-entry into
        matter, a new material) starts after a collision that took the ion to or below the
        wanted energy, a little lower on average (``tests/test_heavy_ions.py`` measures it).
        """
        energies = self._energies.setdefault(ion, set())
        energies.add(round(float(energy), 12))

    def library(self, particle, ion: str, material, energy: float) -> TrajectoryLibrary:
        """The library of the smallest announced energy >= ``energy`` in ``material``."""
        name = str(material.GetName())
        candidates = sorted(e for e in self._energies.get(ion, ()) if e >= energy * (1 - 1e-12))
        target = candidates[0] if candidates else float(energy)
        key = (ion, name, target)
        lib = self._libraries.get(key)
        if lib is None:
            comp = self._compositions.get(name)
            if comp is None:
                comp = self._compositions[name] = Composition.from_g4_material(material)
            mass_amu = float(particle.GetPDGMass()) / float(self.g4.amu_c2)
            lib = trim_library(
                ion,
                int(particle.GetAtomicNumber()),
                mass_amu,
                target,
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

    def _is_vacuum(self, material) -> bool:
        return float(material.GetDensity()) < VACUUM_DENSITY * self.g4.g / self.g4.cm3

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
            material = pv.GetLogicalVolume().GetMaterial()
            if self._is_vacuum(material):
                step = self.nav.ComputeStep(self._vec(pos), self._vec(d), _FAR, 0.0)
                if step >= _FAR:
                    fate.escaped_energy = e
                    break
                pos = pos + step * d
                self.nav.SetGeometricallyLimitedStep()
                pv = self._locate(pos, d, relative=True)
                fate.crossings += 1
                continue
            lib = self.library(particle, ion, material, e)
            rel, energies, arrivals, left = lib.continuation(e, rng)
            points = pos + rel @ rotation_from_x(d).T
            end = self._walk(points, energies, arrivals, pv, fate)
            if end is None:  # the history ended inside matter of this material
                pos = points[-1]
                e = float(energies[-1])
                if not left:
                    e = 0.0
                    break
                # TRIM's layer ended (rare): go on from its last point in the same direction
                d = points[-1] - points[-2]
                d /= np.linalg.norm(d)
                pv = self._locate(pos, d, relative=False)
                continue
            pos, e, d, pv = end
        fate.position = pos
        return fate

    def _walk(
        self, points: np.ndarray, energies: np.ndarray, arrivals: np.ndarray, pv, fate: IonFate
    ):
        """Deposit along ``points`` while they stay in matter of ``pv``'s material.

        A whole piece deposits what the ion loses from one point to the next, collision at the
        end included; a piece cut by a boundary deposits its share of the electronic loss only
        (the collision at its end does not happen).

        Crossing into another volume of the same material (a neighbouring patch, the target
        under a rough layer) keeps the history. Returns ``(point, energy, direction, volume)``
        where it enters other matter or vacuum, or None when the polyline ends.
        """
        g4 = self.g4
        nav = self.nav
        vec = g4.G4ThreeVector
        material = str(pv.GetLogicalVolume().GetMaterial().GetName())
        volume = self.index.get(str(pv.GetLogicalVolume().GetName()))
        m = len(points)
        pieces = points[1:] - points[:-1]
        piece_length = np.sqrt(np.einsum("ij,ij->i", pieces, pieces))
        walked = np.concatenate([[0.0], np.cumsum(piece_length)])  # path length to each point
        i = 0  # the ion is on piece i, from `cur` to points[i + 1]
        cur, e_cur, s_cur = points[0], float(energies[0]), 0.0
        centre = cur
        safety = nav.ComputeSafety(vec(*cur), _FAR, True)
        while i < m - 1:
            # whole pieces whose ends lie in the safety sphere about `centre` are in the volume
            if safety > 0:
                rest = points[i + 1 :] - centre
                outside = np.einsum("ij,ij->i", rest, rest) >= safety * safety
                j = i + (int(np.argmax(outside)) if outside.any() else m - 1 - i)
                if j > i:
                    _add(fate.deposits, volume, e_cur - float(energies[j]))
                    _add(fate.lengths, volume, float(walked[j]) - s_cur)
                    i, cur, e_cur, s_cur = j, points[j], float(energies[j]), float(walked[j])
                    if i >= m - 1:
                        break
            b = points[i + 1]
            length = float(walked[i + 1]) - s_cur
            if length <= 0.0:
                i += 1
                continue
            u = (b - cur) / length
            pa = vec(*cur)
            nav.LocateGlobalPointWithinVolume(pa)
            step = nav.ComputeStep(pa, vec(*u), length, 0.0)
            if step >= length:
                _add(fate.deposits, volume, e_cur - float(energies[i + 1]))
                _add(fate.lengths, volume, length)
                i, cur, e_cur, s_cur = i + 1, b, float(energies[i + 1]), float(walked[i + 1])
                centre = cur
                pb = vec(*cur)
                nav.LocateGlobalPointWithinVolume(pb)
                safety = nav.ComputeSafety(pb, _FAR, True)
                continue
            lost = (e_cur - float(arrivals[i + 1])) * step / length
            _add(fate.deposits, volume, lost)
            _add(fate.lengths, volume, step)
            cur, e_cur, s_cur = cur + step * u, e_cur - lost, s_cur + step
            fate.crossings += 1
            nav.SetGeometricallyLimitedStep()
            nxt = self._locate(cur, u, relative=True)
            if nxt is None or str(nxt.GetLogicalVolume().GetMaterial().GetName()) != material:
                return cur, e_cur, u, nxt
            volume = self.index.get(str(nxt.GetLogicalVolume().GetName()))
            centre, safety = cur, 0.0
        return (
            None  # a stopped history's last energy is 0 (TRIM's <= 1 eV rest is in its last piece)
        )


def _add(table: dict[int, float], key: int | None, value: float) -> None:
    if key is not None and value:
        table[key] = table.get(key, 0.0) + value
