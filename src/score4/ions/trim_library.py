"""Libraries of heavy-ion trajectories computed with TRIM (lunasrim), replayed in any geometry.

Geant4 cannot range slow heavy ions (a 103 keV Pb-206 recoil stops 6x too shallow in Si with
no straggling: ``benchmarks/bench_ion_setups.py``). score4 therefore moves such ions along
trajectories from TRIM's binary-collision Monte Carlo (lunasrim, a digit-exact SRIM-2013).

A :class:`TrajectoryLibrary` holds ``n`` TRIM histories of one ion at one energy entering one
semi-infinite material along +x. Each history is a polyline: the start and the position after
every nuclear collision, with the ion's kinetic energy there. In an amorphous target an ion's
future depends only on its energy and direction, so any history can be continued from the first
point where its energy has fallen to ``E``: rotated so its direction there is the ion's direction,
and shifted to the ion's position (:meth:`TrajectoryLibrary.continuation`). That serves an ion
of any energy up to the library's, born anywhere, and an ion re-entering matter after a flight
through vacuum. The Geant4 side (``score4.sim.heavy_ions``) walks the polyline through the real
volumes and deposits the energy lost on each piece of it in the volume where that piece lies.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import time
from array import array
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from score4.common.units import duration_text

from .. import files
from ..errors import Score4Error
from .composition import Composition

_CROSSING_TOLERANCE = 0.01
_MIN_CHOICE = 20
_REJECTION_TRIES = 64
# Bump when the stored arrays change meaning.
FORMAT_VERSION = 2
ANGSTROM_MM = 1e-7
# TRIM's target: one layer of this many expected ranges, so (almost) no ion crosses it; a history
# that does cross (or leaves through the entry face) ends there and is continued by the walker.
_DEPTH_IN_RANGES = 20.0
#: The cache keeps libraries up to this many bytes in all (the least recently used go first): a
#: library of 1000 103 keV Pb-206 histories in Si takes ~5.7 MB, and every run seed has its own.
CACHE_MAX_BYTES = 2 * 1024**3


@dataclass(frozen=True)
class TrajectoryLibrary:
    """TRIM histories of one ion at one energy in one material (see the module docstring).

    ``points`` (N, 3) mm of all histories one after another; history ``k`` is rows
    ``offsets[k]:offsets[k+1]``. At each point ``arrivals`` (N,) MeV is the ion's energy when it
    gets there and ``energies`` (N,) after its collision there: between two points it loses
    energy continuously (electronic stopping), at a point at once (the nuclear collision).
    ``left[k]`` is True when history ``k`` ended by leaving the TRIM layer (backscattered or
    transmitted) rather than by stopping; its last point is then where it left.
    """

    ion: str
    mass_amu: float
    energy: float
    material: Composition
    offsets: np.ndarray
    points: np.ndarray
    energies: np.ndarray
    arrivals: np.ndarray
    left: np.ndarray

    @property
    def size(self) -> int:
        return len(self.offsets) - 1

    @cached_property
    def walked(self) -> np.ndarray:
        """(N,) mm: path length from its history's start to each point."""
        steps = np.zeros(len(self.points))
        steps[1:] = np.sqrt(((self.points[1:] - self.points[:-1]) ** 2).sum(axis=1))
        steps[self.offsets[:-1]] = 0.0  # each history starts from 0
        total = np.cumsum(steps)
        return total - np.repeat(total[self.offsets[:-1]], np.diff(self.offsets))

    @cached_property
    def columns(self) -> tuple[array, array, array, array, array, array]:
        """``x``, ``y``, ``z`` (of ``points``), ``energies``, ``arrivals`` and ``walked`` as
        flat ``array('d')``, made once: a replay reads a few of a history's values one at a
        time by their absolute index (no slice, no copy: an event's replay then touches a few
        cache lines of the library, not all of the history)."""
        return tuple(  # type: ignore[return-value]
            array("d", np.ascontiguousarray(c, dtype=float).tobytes())
            for c in (*self.points.T, self.energies, self.arrivals, self.walked)
        )

    @cached_property
    def reach(self) -> list[float]:
        """(size,) mm: how far each history gets from its first point (the radius of the
        smallest sphere about that point that holds it all)."""
        counts = np.diff(self.offsets)
        first = self.points[self.offsets[:-1]]
        far = ((self.points - np.repeat(first, counts, axis=0)) ** 2).sum(axis=1)
        return np.sqrt(np.maximum.reduceat(far, self.offsets[:-1])).tolist()

    @cached_property
    def _energy_keys(self) -> np.ndarray:
        """(N,) increasing: history index + a fraction that grows as its energy falls.

        Within a history the energies never rise, so one ``searchsorted`` finds every history's
        first point at or below an energy at once.
        """
        history = np.repeat(np.arange(self.size), np.diff(self.offsets))
        return history + 0.5 * (1.0 - np.clip(self.energies / self.energy, 0.0, 1.0))

    def _crossing(self, energy: float, rng) -> tuple[int, int]:
        """A history and its first point at or below ``energy``, no more than 1 % below it.

        The collision that takes a history below ``energy`` overshoots it, by a large part of
        the energy for a heavy ion's nuclear collisions (in CaWO4 the mean range of a 103 keV
        Pb ion continued from a 200 keV history came out 13 % short). An ion's future depends
        only on its energy and direction, so choosing among the histories whose first point
        below ``energy`` lies within 1 % of it is unbiased to that 1 %. Fewer than
        ``_MIN_CHOICE`` such histories: the ``_MIN_CHOICE`` closest.

        Histories are first drawn at random and the first that qualifies is taken (a uniform
        choice among those that qualify, at a fraction of the cost); after
        ``_REJECTION_TRIES`` misses all histories are looked at.
        """
        fraction = 0.5 * (1.0 - min(max(energy / self.energy, 0.0), 1.0))
        keys, least = self._energy_keys, energy * (1 - _CROSSING_TOLERANCE)
        for _ in range(_REJECTION_TRIES):  # uniform among the histories that qualify
            k = int(rng.integers(self.size))
            i = int(keys.searchsorted(k + fraction))
            if i < self.offsets[k + 1] and self.energies[i] >= least:
                return k, i
        # few qualify: look at all of them
        index = np.searchsorted(keys, np.arange(self.size) + fraction)
        valid = index < self.offsets[1:]
        start = np.where(valid, self.energies[np.minimum(index, len(self.energies) - 1)], -1.0)
        close = np.flatnonzero(start >= energy * (1 - _CROSSING_TOLERANCE))
        if len(close) < _MIN_CHOICE:
            close = np.argsort(-start)[:_MIN_CHOICE]
        k = int(close[rng.integers(len(close))])
        return k, int(index[k])

    def pick(self, energy: float, rng) -> tuple[int, int, int, float]:
        """A random history to continue from kinetic energy ``energy`` (MeV).

        Returns ``(k, i, end, azimuth)``: history ``k`` continues from its point ``i`` to its
        last point ``end - 1``, turned by ``azimuth`` about its first piece there
        (:meth:`frame`). ``rng`` needs ``integers(n)`` and ``uniform(a, b)`` (a numpy
        Generator or :class:`score4.sim.heavy_ions.ReplayStream`).
        """
        if energy > self.energy * (1 + 1e-9):
            raise Score4Error(
                f"{self.ion} of {energy * 1e3:.6g} keV: above the {self.energy * 1e3:.6g} keV "
                f"of its TRIM trajectory library in {self.material.name} (internal error: a "
                f"history can only be continued from an energy it passes through)"
            )
        if energy >= self.energy * (1 - 1e-9):  # from the start: any history, exact
            k = int(rng.integers(self.size))
            i = int(self.offsets[k])
        else:
            k, i = self._crossing(energy, rng)
        end = int(self.offsets[k + 1])
        if i >= end - 1:
            return k, i, end, 0.0
        return k, i, end, float(rng.uniform(0.0, 2 * np.pi))

    def frame(self, i: int, azimuth: float) -> np.ndarray:
        """The rotation that takes the piece from point ``i`` to +x, turned by ``azimuth``."""
        if i in self._starts:  # TRIM's ions enter along +x
            return _spin(azimuth)
        u = self.points[i + 1] - self.points[i]
        return _rotation_to_x(u / np.sqrt(u @ u), azimuth)

    def turn(self, i: int, azimuth: float, direction) -> np.ndarray:
        """The rotation that takes the continuation from point ``i`` (turned by ``azimuth``)
        onto unit vector ``direction``: world offsets are ``(points[i:] - points[i]) @ turn.T``
        (:meth:`rotation` as a 3 x 3 array)."""
        rows = self.rotation(i, azimuth, [float(c) for c in direction])
        return np.array(rows).reshape(3, 3)

    def rotation(self, i: int, azimuth: float, direction) -> tuple[float, ...]:
        """:meth:`turn`'s nine elements row by row, in plain floats (numpy's per-call cost is
        most of a replay): ``rotation_from_x(direction) @ frame(i, azimuth)``; ``direction``
        three floats."""
        ca, sa = math.cos(azimuth), math.sin(azimuth)
        dx, dy, dz = direction
        if dx < -1 + 1e-12:  # the rotation from +x: half a turn about z
            d = ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
        else:  # rows of rotation_from_x(direction), the transpose of _rotation_to_x's base
            f = 1.0 / (1.0 + dx)
            d = (
                (dx, -dy, -dz),
                (dy, 1.0 - f * dy * dy, -f * dy * dz),
                (dz, -f * dy * dz, 1.0 - f * dz * dz),
            )
        # d @ spin(azimuth): spin mixes the 2nd and 3rd columns
        ds = [(r[0], r[1] * ca + r[2] * sa, r[2] * ca - r[1] * sa) for r in d]
        if i in self._starts:  # TRIM's ions enter along +x: the frame is the spin alone
            (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = ds
            return (r00, r01, r02, r10, r11, r12, r20, r21, r22)
        # the piece from point i to +x (_rotation_to_x's base, no spin): ds @ base
        x, y, z = self.columns[0], self.columns[1], self.columns[2]
        ux, uy, uz = x[i + 1] - x[i], y[i + 1] - y[i], z[i + 1] - z[i]
        norm = math.sqrt(ux * ux + uy * uy + uz * uz)
        ux, uy, uz = ux / norm, uy / norm, uz / norm
        if ux < -1 + 1e-12:
            base = ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
        else:
            f = 1.0 / (1.0 + ux)
            base = (
                (ux, uy, uz),
                (-uy, 1.0 - f * uy * uy, -f * uy * uz),
                (-uz, -f * uy * uz, 1.0 - f * uz * uz),
            )
        return tuple(
            r[0] * base[0][c] + r[1] * base[1][c] + r[2] * base[2][c] for r in ds for c in range(3)
        )

    @cached_property
    def _starts(self) -> frozenset[int]:
        return frozenset(int(o) for o in self.offsets[:-1])

    def continuation(
        self, energy: float, rng: np.random.Generator
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """A random history continued from kinetic energy ``energy`` (MeV).

        Returns ``(points, energies, arrivals, left)``: points relative to the start, (m, 3) mm
        with the first row zero and the first piece along +x; the energies after each point's
        collision (the first equal to ``energy``) and on arrival at each point (the first
        equal to ``energy`` too); whether the history ends by leaving TRIM's layer. With
        ``m == 1`` the ion is at rest already (``energy`` below every history's end).
        """
        k, i, end, azimuth = self.pick(energy, rng)
        if i >= end - 1:
            return np.zeros((1, 3)), np.array([energy]), np.array([energy]), False
        rotated = (self.points[i:end] - self.points[i]) @ self.frame(i, azimuth).T
        energies = self.energies[i:end].copy()
        arrivals = self.arrivals[i:end].copy()
        energies[0] = arrivals[0] = energy
        return rotated, energies, arrivals, bool(self.left[k])


def _spin(azimuth: float) -> np.ndarray:
    ca, sa = np.cos(azimuth), np.sin(azimuth)
    return np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])


def _rotation_to_x(u: np.ndarray, azimuth: float) -> np.ndarray:
    """A rotation taking unit vector ``u`` to +x, followed by a turn ``azimuth`` about +x."""
    ux, uy, uz = float(u[0]), float(u[1]), float(u[2])
    spin = _spin(azimuth)
    if ux < -1 + 1e-12:  # u = -x: half a turn about z
        return spin @ np.diag([-1.0, -1.0, 1.0])
    # Rodrigues' formula for the axis u x (+x) = (0, uz, -uy) and cos = ux, in closed form
    f = 1.0 / (1.0 + ux)
    base = np.array(
        [
            [ux, uy, uz],
            [-uy, 1.0 - f * uy * uy, -f * uy * uz],
            [-uz, -f * uy * uz, 1.0 - f * uz * uz],
        ]
    )
    return spin @ base


def rotation_from_x(direction: np.ndarray) -> np.ndarray:
    """A rotation taking +x to the unit vector ``direction`` (any turn about it)."""
    return _rotation_to_x(np.asarray(direction, dtype=float), 0.0).T


# ------------------------------------------------------------------------------------------------
# Building libraries with lunasrim
# ------------------------------------------------------------------------------------------------


def _import_lunasrim():
    try:
        import lunasrim
    except ImportError as err:  # pragma: no cover - lunasrim is a dependency
        raise Score4Error(
            "heavy-ion transport needs the package 'lunasrim' (pip install lunasrim)"
        ) from err
    return lunasrim


def cache_dir() -> Path:
    """Where trajectory libraries are kept: ``$XDG_CACHE_HOME/score4/trim-trajectories``."""
    return files.cache_dir("trim-trajectories")


def library_key(
    ion_z: int, mass_amu: float, energy: float, material: Composition, n: int, seed: int
) -> str:
    lunasrim = _import_lunasrim()
    text = json.dumps(
        [
            FORMAT_VERSION,
            getattr(lunasrim, "__version__", "?"),
            ion_z,
            round(mass_amu, 6),
            round(energy * 1e3, 9),
            [(s, round(f, 12)) for s, f in material.atoms],
            round(material.density, 9),
            *([list(material.masses)] if material.masses else []),
            n,
            seed,
        ]
    )
    return hashlib.sha256(text.encode()).hexdigest()[:24]


#: Told when a library is computed (not read from the cache): ``listener(phase, what, text)``
#: with phase "start" (after the first histories, with an estimate of the time) and "done",
#: ``what`` naming the library and ``text`` the line to show.
_listener: Callable[[str, str, str], None] | None = None
#: Fraction of the histories timed before the time of the whole library is estimated (the
#: first 20 histories of 1000 103 keV Pb-206 in Si took twice the mean time a history).
_ESTIMATE_AFTER = 0.1


def set_build_listener(listener: Callable[[str, str, str], None] | None) -> None:
    """Have ``listener(phase, what, text)`` told when a library is built (a worker sends it
    on to the parent, which shows it)."""
    global _listener
    _listener = listener


def _tell(phase: str, what: str, text: str) -> None:
    if _listener is not None:
        _listener(phase, what, text)


def trim_library(
    ion: str,
    ion_z: int,
    mass_amu: float,
    energy: float,
    material: Composition,
    n: int = 1000,
    seed: int = 1,
    cache: bool = True,
) -> TrajectoryLibrary:
    """The library of ``n`` TRIM histories of ion (Z, mass) at ``energy`` MeV in ``material``.

    Computed once (about 4-9 ms of CPU per 103 keV Pb ion in Si) and kept in score4's cache
    folder, keyed by every input (``seed`` included) and the lunasrim version; processes that
    need the same library at once wait for the one computing it. The cache keeps the most
    recently used libraries up to :data:`CACHE_MAX_BYTES`.
    """
    if n < 1:
        raise Score4Error(f"physics.trim_histories: must be >= 1, got {n}")
    key = library_key(ion_z, mass_amu, energy, material, n, seed)
    path = cache_dir() / f"{key}.npz"
    what = (
        f"TRIM trajectory library of {n} {ion} histories at {energy * 1e3:.4g} keV in "
        f"{material.name}"
    )
    started = time.monotonic()

    def estimate(done: int, first: float) -> None:
        """Told after ``done`` histories, the first of which started at ``first``."""
        now = time.monotonic()
        total = (first - started) + (now - first) / done * n
        _tell(
            "start",
            what,
            f"building the {what}: about {duration_text(total)} (once; then read from "
            f"{cache_dir()}; not counted in the time left)",
        )

    def build() -> TrajectoryLibrary:
        library = _compute(ion, ion_z, mass_amu, energy, material, n, seed, estimate)
        _tell("done", what, f"built the {what} in {duration_text(time.monotonic() - started)}")
        return library

    if not cache:
        return build()
    path.parent.mkdir(parents=True, exist_ok=True)
    # one process computes, the others (workers of the same run) wait and read its file
    with _locked(path.with_suffix(".lock")):
        library = _load(path, ion, mass_amu, energy, material)
        if library is not None:
            return library
        started = time.monotonic()  # the wait for another process's build is not building
        library = build()
        tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
        np.savez_compressed(
            tmp,
            offsets=library.offsets,
            points=library.points,
            energies=library.energies,
            arrivals=library.arrivals,
            left=library.left,
        )
        os.replace(tmp, path)
    prune_cache(keep=path)
    return library


@contextlib.contextmanager
def _locked(lock: Path) -> Iterator[None]:
    with open(lock, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _load(
    path: Path, ion: str, mass_amu: float, energy: float, material: Composition
) -> TrajectoryLibrary | None:
    """The library stored at ``path``, or None (absent; a damaged file is removed)."""
    if not path.exists():
        return None
    try:
        with np.load(path) as data:
            library = TrajectoryLibrary(
                ion,
                mass_amu,
                energy,
                material,
                data["offsets"],
                data["points"],
                data["energies"],
                data["arrivals"],
                data["left"],
            )
    except (OSError, ValueError, KeyError, EOFError):
        path.unlink(missing_ok=True)  # damaged cache entry: compute again
        return None
    os.utime(path)  # recently used: pruned last
    return library


def prune_cache(keep: Path | None = None, max_bytes: int = CACHE_MAX_BYTES) -> int:
    """Delete the least recently used libraries beyond ``max_bytes``; return how many went."""
    entries = []
    for p in cache_dir().glob("*.npz"):
        with contextlib.suppress(OSError):
            st = p.stat()
            entries.append((st.st_mtime, st.st_size, p))
    total = sum(size for _, size, _ in entries)
    removed = 0
    for _, size, p in sorted(entries, key=lambda e: e[0]):
        if total <= max_bytes:
            break
        if p == keep:
            continue
        p.unlink(missing_ok=True)  # (its empty .lock file stays: another process may hold it)
        total -= size
        removed += 1
    return removed


def _compute(
    ion: str,
    ion_z: int,
    mass_amu: float,
    energy: float,
    material: Composition,
    n: int,
    seed: int,
    estimate: Callable[[int, float], None] | None = None,
) -> TrajectoryLibrary:
    lunasrim = _import_lunasrim()
    from lunasrim import api, data_files
    from lunasrim.srim import TRIM, Element, Ion, Layer, Target
    from lunasrim.trim import TrimEngine

    mat = api.material(material.lunasrim_target(), density=material.density)
    energy_kev = energy * 1e3
    table = lunasrim.stopping_table(
        ion_z, mat, emin=energy_kev, emax=energy_kev * 1.0001, units="eV/A", mass=mass_amu
    )
    range_a, straggle_a = table[0][3], table[0][4]
    width = max(_DEPTH_IN_RANGES * (range_a + 3 * straggle_a), 1000.0)
    from .species import SYMBOLS

    elements = {
        Element(z, material.mass_of(SYMBOLS[z - 1]) or m): {
            "stoich": stoich,
            "E_d": api._DISPLACEMENT.get(z, 25),
            "lattice": api._LATTICE,
            "surface": data_files.atomdata(z).heat_sublimation,
        }
        for z, stoich, m in mat.elements
    }
    layer = Layer(
        elements,
        density=mat.density,
        width=width,
        phase=mat.phase,
        name=material.name[:20],
        bragg_correction=mat.correction,
    )
    calc = TRIM(
        Target([layer]),
        Ion(ion_z, energy=energy_kev * 1e3, mass=mass_amu),
        number_ions=n,
        calculation=1,
        random_seed=seed,
    )

    class Recorder(TrimEngine):
        """Keeps the position and the energies before and after every collision.

        (TRIM's own results are unchanged: this only reads the ion's state.)
        """

        def tally_ion_path(self, st, xold, de, tt, atom):
            self.rows.append((st.x, st.y, st.z, st.e, st.e + tt))
            return super().tally_ion_path(st, xold, de, tt, atom)

    engine = Recorder(calc.trim_input())
    offsets = [0]
    # the rows of all histories, flat (5 per point): 8 bytes a value rather than a Python
    # float's 24 and a tuple's 80 per point (a library's peak memory: bench_trim_library_size)
    rows = array("d")
    left = np.zeros(n, dtype=bool)
    first = time.monotonic()
    for k in range(n):
        engine.rows = [(0.0, 0.0, 0.0, engine.e0, engine.e0)]
        state = engine.run_ion()
        if engine.fate in ("B", "T"):  # left the layer: the exit point ends the history
            engine.rows.append((state.x, state.y, state.z, state.e, state.e))
            left[k] = True
        else:  # stopped: TRIM's last energy (<= 1 eV) is deposited where it stops
            engine.rows[-1] = (*engine.rows[-1][:3], 0.0, engine.rows[-1][4])
        for row in engine.rows:
            rows.extend(row)
        offsets.append(offsets[-1] + len(engine.rows))
        if estimate is not None and k + 1 == max(1, round(n * _ESTIMATE_AFTER)):
            estimate(k + 1, first)
    data = np.frombuffer(rows, dtype=float).reshape(-1, 5)
    return TrajectoryLibrary(
        ion,
        mass_amu,
        energy,
        material,
        np.asarray(offsets, dtype=np.int64),
        data[:, :3] * ANGSTROM_MM,
        data[:, 3] * 1e-6,  # eV -> MeV
        data[:, 4] * 1e-6,
        left,
    )


#: Events per 1000 TRIM histories of a library whose size is not given: a run draws its ions'
#: histories with replacement; at up to 20 events per history the library's own sample error
#: was within the scatter of the recoil-deposit spectrum's chi2 at 2e4 and 1e5 events (at most
#: about a fifth of its variance; docs/physics.md, "Library size"). 1000 to 100 000 histories.
EVENTS_PER_THOUSAND_HISTORIES = 20_000


def default_trim_histories(events: int) -> int:
    """TRIM histories of a library when ``physics.trim_histories`` is not given: 1000 per
    :data:`EVENTS_PER_THOUSAND_HISTORIES` events of the run (rounded up), 1000 to 100 000."""
    thousands = -(-int(events) // EVENTS_PER_THOUSAND_HISTORIES)
    return 1000 * min(max(thousands, 1), 100)


def trim_histories(config) -> int:
    """The TRIM library size of a run (its configuration, or a worker's record of it):
    ``physics.trim_histories``, or :func:`default_trim_histories` of its ``run.events``."""
    given = config.physics.trim_histories
    return given if given is not None else default_trim_histories(config.run.events)
