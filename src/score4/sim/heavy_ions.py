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

Python runs per heavy ion, not per Geant4 step. The walk runs in the library's own frame on
flat arrays (a point is turned into the world only where the navigator is asked about it), and
pieces that lie inside the current volume's safety sphere are summed without asking the
navigator (a new sphere about the last point passed, before any piece is stepped through).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import Score4Error
from ..ions.composition import Composition
from ..ions.trim_library import TrajectoryLibrary, trim_library
from ..source.primaries import Primaries

#: Materials thinner than this (g/cm3) are vacuum for a heavy ion: it crosses them in a line.
VACUUM_DENSITY = 1e-5
_MAX_CROSSINGS = 10_000
_FAR = 1e90
#: A ComputeStep this short (mm; G4Navigator's zero-step threshold, 0.05 kCarTolerance) left
#: the ion where it was; after this many in a row the next one is G4Navigator's push of _PUSH.
_ZERO_STEP = 5e-11
_ZEROS_BEFORE_PUSH = 9
_PUSH = 1e-7  # mm, 100 kCarTolerance


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

    Ions heavier than helium of kinetic energy in (0, ``max_energy``] (MeV) with
    ``heavy_ions="trim"`` (an ion at rest, a nuclide source, is Geant4's radioactive decay's),
    and alphas of any energy with ``alphas="trim"`` (the settings ``physics.heavy_ions``,
    ``physics.alphas`` and ``physics.trim_max_energy`` of a run configuration).
    ``definition(name)`` gives the G4ParticleDefinition of a particle name.
    """
    mask = np.zeros(len(primaries), dtype=bool)
    energy = primaries.energy
    for name in np.unique(primaries.particle):
        rows = primaries.particle == name
        if name == "alpha" and alphas == "trim":
            mask |= rows
        elif heavy_ions == "trim" and heavy_ion_z(definition(str(name))):
            mask |= rows & (energy <= max_energy) & (energy > 0)
    return mask


@dataclass
class IonFate:
    """Where a replayed ion ended and what it left behind."""

    position: np.ndarray  # (3,) mm: where it stopped or left the world
    escaped_energy: float  # MeV carried out of the world (0 when it stopped)
    deposits: dict[int, float] = field(default_factory=dict)  # scoring index -> MeV
    lengths: dict[int, float] = field(default_factory=dict)  # scoring index -> mm in matter
    crossings: int = 0  # boundaries crossed
    volume: str = ""  # logical volume where it stopped ("" when it left the world)
    material: str = ""  # material there ("" when it left the world)
    pdg: int = 0  # the ion's PDG code (steps output)
    #: scoring index -> the last point (mm) of the ion's path in that volume (steps output)
    points: dict[int, tuple[float, float, float]] = field(default_factory=dict)
    #: with ``HeavyIonTransport.record_pieces``: (scoring index, mid-point x, y, z mm, MeV) of
    #: every piece of the path that deposited (TRIM's points, cut at boundaries)
    pieces: list[tuple[int, float, float, float, float]] = field(default_factory=list)
    #: global time (ns) the ion started at: 0 for a primary, its creation for a secondary taken
    #: from Geant4 (steps output; TRIM's slowing down takes under a picosecond, so its pieces
    #: all carry this time)
    time: float = 0.0

    @property
    def stopped(self) -> bool:
        """True when the ion came to rest inside the world."""
        return self.escaped_energy == 0.0 and bool(self.volume)


@dataclass(frozen=True)
class _Volume:
    pv: object  # the physical volume's wrapper, kept alive (see HeavyIonTransport._volume)
    logical: str  # logical volume name
    material: object
    material_name: str
    vacuum: bool
    index: int | None  # scoring column, None if not scored


class ReplayStream:
    """A small random stream for one replayed ion: SplitMix64 on Python integers.

    Creating a numpy Generator from a seed sequence costs ~15-60 us, more than the rest of a
    short replay; this stream costs nothing to create and ~0.3 us per draw. It offers the two
    draws the replay uses, ``integers(n)`` and ``uniform(a, b)``.
    """

    __slots__ = ("_state",)
    _MASK = (1 << 64) - 1

    def __init__(self, seed: int, stream: int = 0, index: int = 0) -> None:
        # distinct (seed, stream, index) give distinct, decorrelated starting states
        mixed = self._mix(int(seed) ^ (int(stream) << 40) ^ 0x5C0E4F00D)
        self._state = self._mix(mixed + int(index) * 0x9E3779B97F4A7C15)

    @classmethod
    def _mix(cls, z: int) -> int:
        z &= cls._MASK
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & cls._MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & cls._MASK
        return z ^ (z >> 31)

    def _next(self) -> int:
        self._state = (self._state + 0x9E3779B97F4A7C15) & self._MASK
        return self._mix(self._state)

    def random(self) -> float:
        """Uniform in [0, 1) (53 bits)."""
        return (self._next() >> 11) * (1.0 / 9007199254740992.0)

    def uniform(self, low: float, high: float) -> float:
        return low + (high - low) * self.random()

    def integers(self, n: int) -> int:
        """Uniform in 0 .. n - 1 (n < 2**32; the bias of the multiply-shift is < n / 2**64)."""
        return (self._next() * int(n)) >> 64


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
        #: the scoring columns' names (``index`` values index it)
        self.column_names = list(scoring)
        self.histories = histories
        self.library_seed = library_seed
        self._libraries: dict[tuple[str, str, float], TrajectoryLibrary] = {}
        self._energies: dict[str, list[float]] = {}  # announced start energies, sorted
        self._announced: set[tuple[str, float]] = set()  # (ion, energy) as given to need()
        self._pdg: dict[str, int] = {}  # ion name -> PDG code
        self._compositions: dict[str, Composition] = {}
        self._vacuum = VACUUM_DENSITY * g4.g / g4.cm3
        self._volumes: dict[int, _Volume] = {}
        #: keep every piece of the path with its deposit (``IonFate.pieces``: steps output)
        self.record_pieces = False
        #: zero steps met and pushes G4Navigator made (see :meth:`_locate_after`)
        self.zero_steps = 0
        self.pushes = 0
        self._zeros_in_row = 0

    # -- libraries -------------------------------------------------------------------------------

    def need(self, ion: str, energy: float) -> None:
        """Announce an energy (MeV) an ion starts with: it gets a library of exactly that energy.

        A history continued from its start is exact; one continued from inside (re-entry into
        matter, a new material) starts after a collision that took the ion to or below the
        wanted energy, a little lower on average (``tests/test_heavy_ions.py`` measures it).
        """
        if (ion, energy) in self._announced:  # most replays start at energies seen before
            return
        self._announced.add((ion, energy))
        energies = self._energies.setdefault(ion, [])
        energy = round(float(energy), 12)
        k = bisect.bisect_left(energies, energy)
        if k == len(energies) or energies[k] != energy:
            energies.insert(k, energy)

    def library(
        self, particle, ion: str, material, energy: float, name: str | None = None
    ) -> TrajectoryLibrary:
        """The library of the smallest announced energy >= ``energy`` in ``material``
        (``name``: the material's name, if known)."""
        name = str(material.GetName()) if name is None else name
        energies = self._energies.get(ion, [])
        k = bisect.bisect_left(energies, energy * (1 - 1e-12))
        target = energies[k] if k < len(energies) else float(energy)
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
        x, y, z = v.tolist() if isinstance(v, np.ndarray) else v
        return self.g4.G4ThreeVector(float(x), float(y), float(z))

    def _locate_after(
        self, step: float, x: float, y: float, z: float, ux: float, uy: float, uz: float
    ):
        """The volume an ion at (x, y, z) moving along (ux, uy, uz) is in after a ``step`` the
        navigator limited (SetGeometricallyLimitedStep called): Geant4's relative locate.

        Counts zero steps (``zero_steps``) and the pushes G4Navigator makes after 10 of them in
        a row (``pushes``, its "Stuck Track" warning GeomNav1002: a 1e-7 mm push along the ion's
        direction). Among tessellated blocks a point on the surfaces of two solids that
        disagree (one says the ion enters it, the other that it leaves) bounces the ion between
        them; a fresh locate, also ahead of the ion, lands in the same pair (tried in session 9).
        """
        if step > _ZERO_STEP:
            if self._zeros_in_row >= _ZEROS_BEFORE_PUSH and step <= _PUSH * (1 + 1e-6):
                self.pushes += 1
            self._zeros_in_row = 0
        else:
            self.zero_steps += 1
            self._zeros_in_row += 1
        vec = self.g4.G4ThreeVector
        return self.nav.LocateGlobalPointAndSetup(vec(x, y, z), vec(ux, uy, uz), True, False)

    def _locate(self, point, direction, relative: bool):
        return self.nav.LocateGlobalPointAndSetup(
            self._vec(point), self._vec(direction), relative, False
        )

    def volume_at(self, point) -> _Volume | None:
        """The volume holding ``point`` (mm; None outside the world): its logical volume name
        (``.logical``), material (``.material_name``), whether it is vacuum, scoring column."""
        pv = self._locate(np.asarray(point, float), np.array([0.0, 0.0, 1.0]), relative=False)
        return None if pv is None else self._volume(pv)

    def _is_vacuum(self, material) -> bool:
        return float(material.GetDensity()) < self._vacuum

    def _volume(self, pv) -> _Volume:
        """What the replay needs of a physical volume, asked of Geant4 once per volume.

        Keyed by the wrapper's id: the cache holds the wrapper, so pybind11 hands out the same
        one for the same volume and the id cannot be reused.
        """
        hit = self._volumes.get(id(pv))
        if hit is None:
            logical = pv.GetLogicalVolume()
            material = logical.GetMaterial()
            name = str(logical.GetName())
            hit = _Volume(
                pv,
                name,
                material,
                str(material.GetName()),
                self._is_vacuum(material),
                self.index.get(name),
            )
            self._volumes[id(pv)] = hit
        return hit

    def transport(
        self,
        particle,
        ion: str,
        energy: float,
        position,
        direction,
        rng,
        announce: bool = True,
    ) -> IonFate:
        """Move one ion (``energy`` MeV from ``position`` mm along unit ``direction``).

        ``rng``: a :class:`ReplayStream` or a numpy Generator (``integers``, ``uniform``).
        ``announce``: give this ion a library of exactly its energy (:meth:`need`); with
        False it continues a library of an energy announced before, from inside.
        """
        if announce:
            self.need(ion, energy)
        px, py, pz = position.tolist() if isinstance(position, np.ndarray) else map(float, position)
        dx, dy, dz = (
            direction.tolist() if isinstance(direction, np.ndarray) else map(float, direction)
        )
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        dx, dy, dz = dx / norm, dy / norm, dz / norm
        pdg = self._pdg.get(ion)
        if pdg is None:
            pdg = self._pdg[ion] = int(particle.GetPDGEncoding())
        fate = IonFate(np.zeros(3), 0.0, pdg=pdg)
        nav, vec = self.nav, self.g4.G4ThreeVector
        pv = nav.LocateGlobalPointAndSetup(vec(px, py, pz), vec(dx, dy, dz), False, False)
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
            here = self._volume(pv)
            if here.vacuum:
                step = nav.ComputeStep(vec(px, py, pz), vec(dx, dy, dz), _FAR, 0.0)
                if step >= _FAR:
                    fate.escaped_energy = e
                    break
                px, py, pz = px + step * dx, py + step * dy, pz + step * dz
                nav.SetGeometricallyLimitedStep()
                pv = self._locate_after(step, px, py, pz, dx, dy, dz)
                fate.crossings += 1
                continue
            lib = self.library(particle, ion, here.material, e, here.material_name)
            k, i, end, azimuth = lib.pick(e, rng)
            if i >= end - 1:  # at rest already
                e = 0.0
                break
            turn = lib.rotation(i, azimuth, (dx, dy, dz))
            # the whole history lies within `reach` of its first point
            reach = lib.reach[k] if i == lib.offsets[k] else _FAR
            out = self._walk(lib, i, end, turn, (px, py, pz), reach, e, pv, fate)
            if out is None:  # the history ended inside matter of this material
                x, y, z = lib.columns[0], lib.columns[1], lib.columns[2]
                e = lib.columns[3][end - 1]
                if not lib.left[k]:
                    px, py, pz = _world(turn, (px, py, pz), x, y, z, i, end - 1)
                    e = 0.0
                    break
                # TRIM's layer ended (rare): go on from its last point in the same direction
                ax, ay, az = _world(turn, (px, py, pz), x, y, z, i, end - 2)
                px, py, pz = _world(turn, (px, py, pz), x, y, z, i, end - 1)
                dx, dy, dz = px - ax, py - ay, pz - az
                norm = math.sqrt(dx * dx + dy * dy + dz * dz)
                dx, dy, dz = dx / norm, dy / norm, dz / norm
                pv = nav.LocateGlobalPointAndSetup(vec(px, py, pz), vec(dx, dy, dz), False, False)
                continue
            (px, py, pz), e, (dx, dy, dz), pv = out
        fate.position = np.array((px, py, pz))
        if e == 0.0 and pv is not None:
            here = self._volume(pv)
            fate.volume, fate.material = here.logical, here.material_name
        return fate

    def _walk(
        self,
        lib: TrajectoryLibrary,
        first: int,
        end: int,
        turn: tuple[float, ...],
        origin: tuple[float, float, float],
        reach: float,
        energy: float,
        pv,
        fate: IonFate,
    ):
        """Deposit along ``lib``'s points ``first .. end - 1`` while they stay in matter of
        ``pv``'s material; the polyline is turned by ``turn`` (:meth:`TrajectoryLibrary.rotation`)
        and moved so its point ``first`` is at ``origin``; it lies within ``reach`` of that
        point.

        A whole piece deposits what the ion loses from one point to the next, collision at the
        end included; a piece cut by a boundary deposits its share of the electronic loss only
        (the collision at its end does not happen). The ion has ``energy`` at the first point;
        the library's ``energies``/``arrivals`` are its energy after/before each point's
        collision; ``walked`` its path length to each point.

        Crossing into another volume of the same material (a neighbouring patch, the target
        under a rough layer) keeps the history. Returns ``(point, energy, direction, volume)``
        where it enters other matter or vacuum, or None when the polyline ends.

        The walk runs in the library's own frame (distances do not change under a rotation):
        a point is turned into the world only where the navigator is asked about it. Points
        within the safety distance of the last point the navigator was asked about are inside
        the volume and passed in one go: all of them when the history's ``reach`` is within
        it, else the path length from that point bounds their distance (a bisection) and the
        next few are tested one by one; only the piece that leaves the sphere is asked about
        (``ComputeStep``, which moves the navigator to its start itself). Plain floats:
        per-piece numpy calls cost more than the arithmetic.
        """
        nav = self.nav
        vec = self.g4.G4ThreeVector
        rec = fate.pieces if self.record_pieces else None
        here = self._volume(pv)
        material, volume = here.material_name, here.index
        xs, ys, zs, es, ars, ws = lib.columns
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = turn
        ox, oy, oz = origin
        x0, y0, z0 = xs[first], ys[first], zs[first]
        last = end - 1
        i = first  # the ion is on piece i, from (cx, cy, cz) to point i + 1 (library frame)
        cx, cy, cz = x0, y0, z0
        wx, wy, wz = ox, oy, oz  # the current point in the world
        e_cur, s_cur = energy, ws[first]
        dep = length_in = 0.0  # in `volume`, not yet booked
        # the caller located the navigator at the first point
        safety = nav.ComputeSafety(vec(wx, wy, wz), _FAR, True)
        bisect_left = bisect.bisect_left
        while i < last:
            # points inside the safety sphere about the current point are in the volume
            if safety > 0.0:
                if reach < safety:  # all of them (the first sphere only)
                    j = last
                else:
                    j = bisect_left(ws, s_cur + safety, i + 1, end) - 1  # path-length bound
                    s2 = safety * safety
                    while j < last:
                        dx, dy, dz = xs[j + 1] - cx, ys[j + 1] - cy, zs[j + 1] - cz
                        if dx * dx + dy * dy + dz * dz >= s2:
                            break
                        j += 1
                if j > i:
                    if rec is not None and volume is not None:
                        px, py, pz, pe = cx, cy, cz, e_cur
                        for m in range(i + 1, j + 1):
                            x2, y2, z2 = xs[m], ys[m], zs[m]
                            mid = ((px + x2) / 2, (py + y2) / 2, (pz + z2) / 2)
                            rec.append(
                                (volume, *_turned(turn, origin, x0, y0, z0, *mid), pe - es[m])
                            )
                            px, py, pz, pe = x2, y2, z2, es[m]
                    dep += e_cur - es[j]
                    length_in += ws[j] - s_cur
                    i, cx, cy, cz, e_cur, s_cur = j, xs[j], ys[j], zs[j], es[j], ws[j]
                    ax, ay, az = cx - x0, cy - y0, cz - z0
                    wx = ox + r00 * ax + r01 * ay + r02 * az
                    wy = oy + r10 * ax + r11 * ay + r12 * az
                    wz = oz + r20 * ax + r21 * ay + r22 * az
                    if i >= last:
                        break
                    # a sphere about the new point (its next point is often in it: one call
                    # instead of a step to it and a sphere about it)
                    reach = _FAR
                    safety = nav.ComputeSafety(vec(wx, wy, wz), _FAR, True)
                    continue
            # the next point is outside the sphere about this one: step to it
            length = ws[i + 1] - s_cur
            if length <= 0.0:
                i += 1
                continue
            inv = 1.0 / length
            lx, ly, lz = (xs[i + 1] - cx) * inv, (ys[i + 1] - cy) * inv, (zs[i + 1] - cz) * inv
            ux = r00 * lx + r01 * ly + r02 * lz
            uy = r10 * lx + r11 * ly + r12 * lz
            uz = r20 * lx + r21 * ly + r22 * lz
            step = nav.ComputeStep(vec(wx, wy, wz), vec(ux, uy, uz), length, 0.0)
            if step >= length:
                i += 1
                if rec is not None and volume is not None:
                    mid = ((cx + xs[i]) / 2, (cy + ys[i]) / 2, (cz + zs[i]) / 2)
                    rec.append((volume, *_turned(turn, origin, x0, y0, z0, *mid), e_cur - es[i]))
                dep += e_cur - es[i]
                length_in += length
                cx, cy, cz, e_cur, s_cur = xs[i], ys[i], zs[i], es[i], ws[i]
                ax, ay, az = cx - x0, cy - y0, cz - z0
                wx = ox + r00 * ax + r01 * ay + r02 * az
                wy = oy + r10 * ax + r11 * ay + r12 * az
                wz = oz + r20 * ax + r21 * ay + r22 * az
                safety = nav.ComputeSafety(vec(wx, wy, wz), _FAR, True)
                continue
            lost = (e_cur - ars[i + 1]) * step * inv
            wx, wy, wz = wx + step * ux, wy + step * uy, wz + step * uz
            if rec is not None and volume is not None:
                h = 0.5 * step
                rec.append((volume, wx - h * ux, wy - h * uy, wz - h * uz, lost))
            dep += lost
            length_in += step
            cx, cy, cz = cx + step * lx, cy + step * ly, cz + step * lz
            e_cur, s_cur = e_cur - lost, s_cur + step
            fate.crossings += 1
            _book(fate, volume, dep, length_in, (wx, wy, wz))
            dep = length_in = 0.0
            nav.SetGeometricallyLimitedStep()
            nxt = self._locate_after(step, wx, wy, wz, ux, uy, uz)
            if nxt is None:
                return (wx, wy, wz), e_cur, (ux, uy, uz), nxt
            there = self._volume(nxt)
            if there.material_name != material:
                return (wx, wy, wz), e_cur, (ux, uy, uz), nxt
            volume = there.index
            safety = 0.0
        _book(fate, volume, dep, length_in, (wx, wy, wz))
        # a stopped history's last energy is 0 (TRIM's <= 1 eV rest is in its last piece)
        return None


def _turned(turn, origin, x0, y0, z0, x, y, z) -> tuple[float, float, float]:
    """Library point (x, y, z) in the world: turned by ``turn`` about library point
    (x0, y0, z0), which goes to ``origin``."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = turn
    ax, ay, az = x - x0, y - y0, z - z0
    return (
        origin[0] + r00 * ax + r01 * ay + r02 * az,
        origin[1] + r10 * ax + r11 * ay + r12 * az,
        origin[2] + r20 * ax + r21 * ay + r22 * az,
    )


def _world(turn, origin, xs, ys, zs, first: int, m: int) -> tuple[float, float, float]:
    """Point ``m`` of a library's columns in the world (its point ``first`` at ``origin``)."""
    return _turned(turn, origin, xs[first], ys[first], zs[first], xs[m], ys[m], zs[m])


def _book(
    fate: IonFate,
    volume: int | None,
    deposit: float,
    length: float,
    where: tuple[float, float, float],
) -> None:
    if volume is not None:
        if deposit:
            fate.deposits[volume] = fate.deposits.get(volume, 0.0) + deposit
            fate.points[volume] = where
        if length:
            fate.lengths[volume] = fate.lengths.get(volume, 0.0) + length
