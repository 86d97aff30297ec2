"""Primaries handed to Geant4 event by event, some rows kept back (TRIM replay, untracked photons).

Shared by score4's own application (:class:`score4.sim.simulation.Simulation`) and the primary
generator of the library (:class:`score4.api.PrimaryGenerator`), so that a user's geant4_pybind
program and ``score4 run`` fill their events the same way:

* every event may start from its own Geant4 seed (:func:`score4.runner.seeds.event_geant4_seeds`),
  set when the event's primaries are generated, so its result does not depend on the events
  tracked before it;
* rows can be kept from Geant4 (``skip``): the heavy ions
  :func:`score4.sim.heavy_ions.trim_mask` marks, which follow TRIM trajectories
  (:func:`replay_row`; score4's application replays them before Geant4 tracks the batch, or
  with per-atom histories just before their event, the library after it), each from a random
  stream of its own (:meth:`EventFeed.replay_rng`), so the replay too is the same in any
  chunking; and photons lite physics cannot track.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..source.primaries import Primaries
from .heavy_ions import ReplayStream

#: Mixed into the seeds of the heavy-ion replay's random streams.
REPLAY_STREAM = 0x5C0E4
#: events with at most this many rows are looked at row by row (numpy costs more there)
_FEW_ROWS = 16


class EventFeed:
    """A batch of events ready for Geant4.

    Parameters
    ----------
    g4
        The geant4_pybind module.
    primaries
        The batch's primaries (one row per particle, events numbered from 0).
    definitions
        The ``G4ParticleDefinition`` of every row.
    g4_seed
        One Geant4 seed for the whole batch (set once by the caller), or one per event
        (``(n_events,)`` integers), set as each event is generated.
    skip
        Rows not given to Geant4 (heavy ions for the TRIM replay, photons lite physics cannot
        track); None: none.
    positions
        Where each row starts in Geant4 (default: the primaries' positions; portal tiling maps
        vertices in a portal box to their subworld point).
    reseed
        With per-event seeds: set Geant4's seed to the event's when filling it (False: the
        seeds only make the replay's random streams).
    own_gun
        The gun is this feed's alone during the run (score4's own application): the particle
        and energy are set only when they change. False (a user's gun, :mod:`score4.api`): set
        for every row.
    """

    def __init__(
        self,
        g4,
        primaries: Primaries,
        definitions: Sequence,
        g4_seed: int | np.ndarray,
        skip: np.ndarray | None = None,
        positions: np.ndarray | None = None,
        reseed: bool = True,
        own_gun: bool = False,
    ) -> None:
        self.g4 = g4
        self.own_gun = own_gun
        self.reseed = reseed
        self.primaries = primaries
        self.definitions = list(definitions)
        self.offsets = primaries.event_offsets()
        self._first = self.offsets.tolist()  # Python ints: read per event
        # Python floats of what never changes during a run (positions may: per-atom histories
        # move their atoms), read per row
        self._energy = primaries.energy.tolist()
        self._direction = primaries.direction.tolist()
        self.skip = np.zeros(len(primaries), dtype=bool) if skip is None else np.asarray(skip)
        self.positions = primaries.position if positions is None else positions
        self.seeds = np.asarray(g4_seed)
        if self.seeds.ndim and len(self.seeds) != primaries.n_events:
            raise ValueError(
                f"g4_seed: need one seed per event ({primaries.n_events}), got {len(self.seeds)}"
            )
        # what this feed last gave the gun (each run has its own feed: it sets both again)
        self._gun_definition: object = None
        self._gun_energy = math.nan
        self._seeds: list[int] = self.seeds.tolist() if self.seeds.ndim else []  # per event
        self._batch_rng = (
            ReplayStream(int(self.seeds), REPLAY_STREAM) if self.seeds.ndim == 0 else None
        )

    @property
    def n_events(self) -> int:
        return self.primaries.n_events

    def rows_of(self, k: int, mask: np.ndarray) -> list[int]:
        """The rows of event ``k`` that ``mask`` (one entry per row) marks."""
        first, end = self._first[k], self._first[k + 1]
        if end - first <= _FEW_ROWS:  # a few rows: cheaper one by one than through numpy
            return [row for row in range(first, end) if mask[row]]
        return (first + np.flatnonzero(mask[first:end])).tolist()

    def geant4_rows(self, k: int) -> list[int]:
        """The rows of event ``k`` given to Geant4, in the order of their primary tracks."""
        skip, first, end = self.skip, self._first[k], self._first[k + 1]
        if end - first <= _FEW_ROWS:
            return [row for row in range(first, end) if not skip[row]]
        return (first + np.flatnonzero(~skip[first:end])).tolist()

    def fill(self, gun, event, k: int) -> None:
        """Put event ``k``'s primaries (all but the skipped rows) into the G4Event ``event``
        through the G4ParticleGun ``gun``; set the event's Geant4 seed first if it has one."""
        g4 = self.g4
        if self._seeds and self.reseed:
            g4.G4Random.setTheSeed(self._seeds[k])
        vector, energy, direction = g4.G4ThreeVector, self._energy, self._direction
        for row in self.geant4_rows(k):
            # the gun keeps its particle and energy: set them only when they change (we never
            # set a momentum, so setting the same particle again changes nothing)
            definition, e = self.definitions[row], energy[row]
            if definition is not self._gun_definition:
                gun.SetParticleDefinition(definition)
                self._gun_definition = definition if self.own_gun else None
            if e != self._gun_energy:
                gun.SetParticleEnergy(e)
                self._gun_energy = e if self.own_gun else math.nan
            gun.SetParticlePosition(vector(*self.positions[row].tolist()))
            gun.SetParticleMomentumDirection(vector(*direction[row]))
            gun.GeneratePrimaryVertex(event)

    def replay_rng(self, k: int, row: int) -> ReplayStream:
        """The random stream of the replay of row ``row`` of event ``k``: its own with per-event
        seeds (so the first N events of a run replay the same in a longer run), else the
        batch's."""
        if self._batch_rng is not None:
            return self._batch_rng
        return ReplayStream(self._seeds[k], REPLAY_STREAM, row - self._first[k])


def replay_row(transport, feed: EventFeed, k: int, row: int):
    """Move row ``row`` (kept from Geant4) of event ``k`` along a TRIM trajectory with
    :class:`score4.sim.heavy_ions.HeavyIonTransport` ``transport``; returns its
    :class:`~score4.sim.heavy_ions.IonFate` (deposits by scoring index)."""
    p = feed.primaries
    return transport.transport(
        feed.definitions[row],
        str(p.particle[row]),
        feed._energy[row],
        feed.positions[row],  # portal tiling: the subworld point
        feed._direction[row],
        feed.replay_rng(k, row),
    )
