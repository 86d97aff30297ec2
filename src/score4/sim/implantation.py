"""Recoil implantation along a decay chain: each decay happens where its atom is.

A chain source with ``implantation`` gives per-atom histories
(:meth:`score4.decay.chain.ChainEvents.histories`): every decay of each deposited head atom, in
time order, all at the atom's deposit vertex, with the columns ``atom`` and ``decay_index``.
While Geant4 runs the chunk, :class:`AtomTracker` follows each atom:

* its first decay happens at the deposit (the vertex the source sampled);
* an alpha decay's recoil ion is replayed on TRIM (:mod:`score4.sim.heavy_ions`) before the
  event is tracked; where it stops is where the atom is from then on, so the atom's later
  decays (in this event, with a long coincidence window, or in its later events) start
  there: deeper in the same volume, in a neighbouring volume (a recoil that leaves a face
  into vacuum flies straight and may stop in the face opposite), in matter that is not
  scored, or nowhere: a recoil that leaves the world takes the atom with it, and the atom's
  later decays are **lost** (they happen outside the geometry; the run drops them and counts
  them);
* beta decays, electron capture and gamma transitions do not move the atom (their recoils
  carry at most tens of eV: well under a nanometre).

Per row the tracker sets the ``vertex`` column (:data:`VERTEX_CODES`), the position, and the
``depth`` column of a moved vertex in the deposit's volume: its depth below the plane of the
surface at the deposit, ``depth0 + (x - x0) . (-n0)`` (``n0`` the outward normal there,
columns ``normal_x/y/z``): exact on a flat face, the local facet's plane on a rough one. A
vertex in another volume has no depth (NaN); a bulk source has no depth column.

Python runs per decay and per recoil (with the replay it already runs), never per step.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable

import numpy as np

from ..source.primaries import Primaries, atom_histories
from .heavy_ions import HeavyIonTransport, IonFate

__all__ = ["VERTEX_CODES", "AtomTracker", "drop_lost", "is_history"]

#: ``vertex`` column: where a decay happened.
VERTEX_CODES = {
    0: "deposit: the vertex the source sampled (the atom has not moved)",
    1: "implanted: moved by alpha recoils, in the volume of its deposit",
    2: "moved: by a recoil into another volume",
    3: "lost: its atom left the world (dropped from the results)",
}
DEPOSIT, IMPLANTED, MOVED, LOST = 0, 1, 2, 3
_NUDGE = 1e-7  # mm: a deposit on the surface itself is looked up 1 A inward
_NOT_RECOILS = ("alpha", "e-", "e+", "gamma", "geantino")


def is_history(primaries: Primaries) -> bool:
    """True for per-atom histories (the columns ``atom`` and ``decay_index``)."""
    return atom_histories(primaries)


class AtomTracker:
    """Follows the atoms of one batch of per-atom histories (see the module docstring).

    ``positions``: the array the primary generator reads (moved vertices are written there and
    into ``primaries``); ``transport``: the heavy-ion replay, whose navigator locates volumes;
    ``depth_of(points, rows)``: depths below the source's surface of points that lie in the
    volume of the deposits of rows ``rows`` (:meth:`score4.source.depth.VertexSampler.depth_of`),
    or None (no depth column).
    """

    def __init__(
        self,
        primaries: Primaries,
        positions: np.ndarray,
        transport: HeavyIonTransport,
        depth_of: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    ) -> None:
        ex = primaries.extra
        self.primaries = primaries
        self.positions = positions
        self.transport = transport
        self.atom = np.asarray(ex["atom"])
        self.decay_index = np.asarray(ex["decay_index"])
        self.depth = ex.get("depth") if depth_of is not None else None
        self.depth_of = depth_of
        self.normal = (
            np.column_stack([ex[f"normal_{a}"] for a in "xyz"]) if "normal_x" in ex else None
        )
        self.vertex = np.zeros(len(primaries), np.int8)
        ex["vertex"] = self.vertex
        self.deposit_row = np.arange(len(primaries))  # the first row of each row's atom
        self.recoil = ~np.isin(primaries.particle, _NOT_RECOILS)
        # does the atom decay again after this row's decay? (its daughter is a chain member)
        self.has_next = np.zeros(len(self.atom), bool)
        if len(self.atom):
            local = self.atom - self.atom.min()
            last = np.full(int(local.max()) + 1, -1)
            np.maximum.at(last, local, self.decay_index)
            self.has_next = self.decay_index < last[local]
        self.counts: Counter[str] = Counter()
        self.stopped_in: Counter[str] = Counter()
        # recoils that stayed in their volume: (deposit row, from, to; from the deposit?)
        self._moves: list[tuple[int, np.ndarray, np.ndarray, bool]] = []
        self._atom = -1  # the atom being followed
        self._deposit = 0  # its first row
        self._volume: object = None  # volume key of the deposit
        self._at: object = None  # volume key where the atom is now
        self._pos = np.zeros(3)
        self._code = DEPOSIT

    # -- volumes ---------------------------------------------------------------------------

    def _key(self, logical: str) -> tuple[str, object]:
        """A volume as the run scores it: its scoring column, else its logical volume."""
        column = self.transport.index.get(logical)
        return ("column", column) if column is not None else ("logical", logical)

    def _label(self, key: tuple[str, object]) -> str:
        kind, value = key
        if kind == "column":
            return str(self.transport.column_names[int(value)])  # type: ignore[call-overload]
        return f"{value} (not scored)"

    def _deposit_volume(self, row: int) -> tuple[str, object]:
        x = self.positions[row]
        here = self.transport.volume_at(x)
        if (here is None or here.vacuum) and self.normal is not None:
            here = self.transport.volume_at(x - _NUDGE * self.normal[row])
        return self._key(here.logical) if here is not None else ("logical", "")

    # -- per decay ---------------------------------------------------------------------------

    def place(self, a: int, b: int) -> bool:
        """Put the decay of rows ``a .. b - 1`` where its atom is; False if the atom is gone."""
        atom = int(self.atom[a])
        if atom != self._atom:  # a new atom: at its deposit
            self._atom, self._deposit = atom, a
            self._pos = self.positions[a].copy()
            self._volume = self._at = self._deposit_volume(a)
            self._code = DEPOSIT
        self.vertex[a:b] = self._code
        self.deposit_row[a:b] = self._deposit
        if self._code == LOST:
            self.counts["lost_decays"] += 1
            return False
        if self._code != DEPOSIT:
            self.positions[a:b] = self._pos
            if self.positions is not self.primaries.position:
                self.primaries.position[a:b] = self._pos
        return True

    def moved(self, row: int, fate: IonFate) -> None:
        """The recoil of row ``row`` (of the decay just placed) ended as ``fate``."""
        if not self.has_next[row]:
            return  # the daughter is stable or outside the chain: nothing decays there
        self.counts["recoils"] += 1
        if not fate.stopped:
            self.counts["left_world"] += 1
            self._code, self._pos = LOST, np.asarray(fate.position, float)
            return
        key = self._key(fate.volume)
        self.stopped_in[self._label(key)] += 1
        before, start = self._at, self._pos
        self._pos, self._at = np.asarray(fate.position, float), key
        from_deposit = self._code == DEPOSIT
        self._code = IMPLANTED if key == self._volume else MOVED
        if key != before:
            self.counts["other_volume"] += 1
            if key[0] == "logical":
                self.counts["unscored_volume"] += 1
        elif self._code == IMPLANTED and self.depth is not None:
            self._moves.append((self._deposit, start, self._pos, from_deposit))
        else:
            self.counts["same_volume"] += 1

    def not_replayed(self, row: int) -> None:
        """A recoil that was not replayed (above ``trim_max_energy``): the atom stays."""
        if self.has_next[row]:
            self.counts["recoils"] += 1
            self.counts["not_replayed"] += 1

    def finish(self) -> None:
        """After the batch: depths of the moved vertices (one numpy pass), and whether each
        recoil that stayed in its volume went deeper or shallower."""
        if self.depth is None or self.depth_of is None:
            return
        self.depth[self.vertex == MOVED] = np.nan
        rows = np.flatnonzero(self.vertex == IMPLANTED)
        if len(rows):
            self.depth[rows] = self.depth_of(self.positions[rows], self.deposit_row[rows])
        if self._moves:
            dep = np.array([m[0] for m in self._moves])
            start = np.array([m[1] for m in self._moves])
            end = np.array([m[2] for m in self._moves])
            before = self.depth_of(start, dep)
            first = np.array([m[3] for m in self._moves])
            before[first] = self.depth[dep[first]]  # from the deposit: its sampled depth
            after = self.depth_of(end, dep)
            self.counts["deeper"] += int((after > before).sum())
            self.counts["shallower"] += int((after <= before).sum())
            self._moves.clear()

    def summary(self) -> dict:
        """Counts of this batch for the run record (:func:`score4.runner.output.chunk_counts` adds
        up the chunks')."""
        keys = (
            "recoils",
            "deeper",
            "shallower",
            "same_volume",
            "other_volume",
            "unscored_volume",
            "left_world",
            "not_replayed",
            "lost_decays",
            "lost_events",
        )
        out: dict = {k: int(self.counts[k]) for k in keys}
        out["stopped_in"] = dict(self.stopped_in)
        return out


def drop_lost(
    primaries: Primaries, scores: dict[str, np.ndarray], columns: dict[str, np.ndarray]
) -> tuple[Primaries, dict[str, np.ndarray], dict[str, np.ndarray], int]:
    """The batch without its lost decays (``vertex == 3``) and the events left empty.

    Returns the primaries, scores and per-event columns that remain, and the number of
    events dropped. A lost decay never reached Geant4: its events' scores do not change.
    """
    vertex = primaries.extra.get("vertex")
    if vertex is None or not (vertex == LOST).any():
        return primaries, scores, columns, 0
    keep = vertex != LOST
    n = primaries.n_events
    kept_events = np.zeros(n, bool)
    kept_events[primaries.event[keep]] = True
    renumber = np.cumsum(kept_events) - 1
    out = Primaries(
        event=renumber[primaries.event[keep]],
        particle=primaries.particle[keep],
        energy=primaries.energy[keep],
        position=primaries.position[keep],
        direction=primaries.direction[keep],
        extra={k: v[keep] for k, v in primaries.extra.items()},
    )
    return (
        out,
        {k: v[kept_events] for k, v in scores.items()},
        {k: np.asarray(v)[kept_events] for k, v in columns.items()},
        int(n - kept_events.sum()),
    )
