"""The TRIM replay's walk as it was before the fast one (score4 0.x, session 7): the reference
of ``test_replay_equivalence``.

It rotates the whole continuation with numpy, copies its columns and asks the navigator about
every piece that leaves a safety sphere (relocating before each question). The fast walk in
``score4.sim.heavy_ions`` does the same physics with fewer navigator calls and in the
library's own frame, so its deposits differ from these in the last bits only where the
arithmetic differs, and in the fate of a recoil only where a rounding decides a boundary.
Run in spawned processes (it needs Geant4).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from score4.errors import Score4Error
from score4.sim.heavy_ions import _FAR, _MAX_CROSSINGS, HeavyIonTransport, IonFate, _book

_LISTS: dict[int, tuple] = {}


def _lists(lib):
    """The library's columns as lists, made once per library (as the old code did)."""
    hit = _LISTS.get(id(lib))
    if hit is None or hit[0] is not lib:
        hit = _LISTS[id(lib)] = (
            lib,
            (lib.energies.tolist(), lib.arrivals.tolist(), lib.walked.tolist()),
        )
    return hit[1]


class ReferenceTransport(HeavyIonTransport):
    """:class:`HeavyIonTransport` with the previous walk (same libraries, same draws)."""

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
        pos = np.array(position, dtype=float)
        dx, dy, dz = (float(c) for c in direction)
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        d = np.array([dx / norm, dy / norm, dz / norm])
        pdg = self._pdg.get(ion)
        if pdg is None:
            pdg = self._pdg[ion] = int(particle.GetPDGEncoding())
        fate = IonFate(pos, 0.0, pdg=pdg)
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
            here = self._volume(pv)
            if here.vacuum:
                step = self.nav.ComputeStep(self._vec(pos), self._vec(d), _FAR, 0.0)
                if step >= _FAR:
                    fate.escaped_energy = e
                    break
                pos = pos + step * d
                self.nav.SetGeometricallyLimitedStep()
                pv = self._locate(pos, d, relative=True)
                fate.crossings += 1
                continue
            lib = self.library(particle, ion, here.material, e, here.material_name)
            k, i, end, azimuth = lib.pick(e, rng)
            if i >= end - 1:  # at rest already
                e = 0.0
                break
            # from a history's start (at TRIM's origin, exactly 0) the offsets are the points
            offsets = lib.points[i:end] - lib.points[i]
            points = pos + offsets @ lib.turn(i, azimuth, d).T
            energies, arrivals, walked = _lists(lib)
            out = self._walk(points, e, energies[i:end], arrivals[i:end], walked[i:end], pv, fate)
            if out is None:  # the history ended inside matter of this material
                pos = points[-1]
                e = energies[end - 1]
                if not lib.left[k]:
                    e = 0.0
                    break
                # TRIM's layer ended (rare): go on from its last point in the same direction
                d = points[-1] - points[-2]
                d /= math.sqrt(float(d @ d))
                pv = self._locate(pos, d, relative=False)
                continue
            pos, e, d, pv = out
        fate.position = pos
        if e == 0.0 and pv is not None:
            here = self._volume(pv)
            fate.volume, fate.material = here.logical, here.material_name
        return fate

    def _walk(
        self,
        points: np.ndarray,
        energy: float,
        energies: list[float],
        arrivals: list[float],
        walked: list[float],
        pv,
        fate: IonFate,
    ):
        """Deposit along ``points`` while they stay in matter of ``pv``'s material.

        A whole piece deposits what the ion loses from one point to the next, collision at the
        end included; a piece cut by a boundary deposits its share of the electronic loss only
        (the collision at its end does not happen). ``energies``/``arrivals``: the ion's energy
        after/before each point's collision (at the first point it has ``energy``);
        ``walked``: path length to each point (from any origin).

        Crossing into another volume of the same material (a neighbouring patch, the target
        under a rough layer) keeps the history. Returns ``(point, energy, direction, volume)``
        where it enters other matter or vacuum, or None when the polyline ends.

        Points within the safety distance of the last point the navigator was asked about are
        inside the volume and passed in one go: the path length from that point bounds their
        distance (a bisection), and the next few are tested one by one; only the piece that
        leaves the sphere is asked about (``ComputeStep``). Plain floats: per-piece numpy calls
        cost more than the arithmetic.
        """
        nav = self.nav
        vec = self.g4.G4ThreeVector
        rec = fate.pieces if self.record_pieces else None
        here = self._volume(pv)
        material, volume = here.material_name, here.index
        xs, ys, zs = points.T.tolist()
        es, ars, ws = energies, arrivals, walked  # the caller's copies (list slices)
        es[0] = ars[0] = energy
        last = len(xs) - 1
        i = 0  # the ion is on piece i, from (cx, cy, cz) to point i + 1
        cx, cy, cz = xs[0], ys[0], zs[0]
        e_cur, s_cur = energy, ws[0]
        dep = length_in = 0.0  # in `volume`, not yet booked
        located = vec(cx, cy, cz)  # where the navigator stands (the caller located it there)
        safety = nav.ComputeSafety(located, _FAR, True)
        bisect_left = bisect.bisect_left
        while i < last:
            # points inside the safety sphere about the current point are in the volume
            if safety > 0.0:
                j = bisect_left(ws, s_cur + safety, i + 1) - 1  # path-length bound
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
                            rec.append(
                                (volume, (px + x2) / 2, (py + y2) / 2, (pz + z2) / 2, pe - es[m])
                            )
                            px, py, pz, pe = x2, y2, z2, es[m]
                    dep += e_cur - es[j]
                    length_in += ws[j] - s_cur
                    i, cx, cy, cz, e_cur, s_cur = j, xs[j], ys[j], zs[j], es[j], ws[j]
                    located = None
                    if i >= last:
                        break
            length = ws[i + 1] - s_cur
            if length <= 0.0:
                i += 1
                continue
            inv = 1.0 / length
            ux, uy, uz = (xs[i + 1] - cx) * inv, (ys[i + 1] - cy) * inv, (zs[i + 1] - cz) * inv
            if located is None:
                located = vec(cx, cy, cz)
                nav.LocateGlobalPointWithinVolume(located)
            step = nav.ComputeStep(located, vec(ux, uy, uz), length, 0.0)
            if step >= length:
                i += 1
                if rec is not None and volume is not None:
                    mid = ((cx + xs[i]) / 2, (cy + ys[i]) / 2, (cz + zs[i]) / 2)
                    rec.append((volume, *mid, e_cur - es[i]))
                dep += e_cur - es[i]
                length_in += length
                cx, cy, cz, e_cur, s_cur = xs[i], ys[i], zs[i], es[i], ws[i]
                located = vec(cx, cy, cz)
                nav.LocateGlobalPointWithinVolume(located)
                safety = nav.ComputeSafety(located, _FAR, True)
                continue
            lost = (e_cur - ars[i + 1]) * step * inv
            if rec is not None and volume is not None:
                h = 0.5 * step
                rec.append((volume, cx + h * ux, cy + h * uy, cz + h * uz, lost))
            dep += lost
            length_in += step
            cx, cy, cz = cx + step * ux, cy + step * uy, cz + step * uz
            e_cur, s_cur = e_cur - lost, s_cur + step
            fate.crossings += 1
            _book(fate, volume, dep, length_in, (cx, cy, cz))
            dep = length_in = 0.0
            cur, u = np.array([cx, cy, cz]), np.array([ux, uy, uz])
            nav.SetGeometricallyLimitedStep()
            nxt = self._locate(cur, u, relative=True)
            if nxt is None:
                return cur, e_cur, u, nxt
            there = self._volume(nxt)
            if there.material_name != material:
                return cur, e_cur, u, nxt
            volume = there.index
            located = vec(cx, cy, cz)  # _locate put the navigator here
            safety = 0.0
        _book(fate, volume, dep, length_in, (cx, cy, cz))
        # a stopped history's last energy is 0 (TRIM's <= 1 eV rest is in its last piece)
        return None
