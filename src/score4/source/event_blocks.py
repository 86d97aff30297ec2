"""Prefix-stable primaries: events are drawn in fixed blocks, each with its own random stream.

Event ``k`` of a run belongs to block ``k // BLOCK_EVENTS``. A block's primaries are always drawn
whole, from a numpy stream derived from (run seed, block index) alone, and then cut to the
events asked for. So the first N events of a run are the same events (vertices, directions,
energies) whatever the number of events, the chunk size or the number of workers: a run with
``--events 5000`` is the first 5000 events of the same run with ``--events 20000``.

With per-atom histories (a chain with implantation, whose primaries carry an ``atom`` column)
the unit is the deposited atom: a block is ``BLOCK_EVENTS`` atoms with all their decays, and a
chunk takes whole atoms (all events of an atom stay in one chunk), renumbered from event 0.

The cost is at most one block drawn in excess at each end of a chunk (sampling 1000 vertices
takes milliseconds; tracking them in Geant4 takes seconds), so chunks need not fall on block
boundaries, although the planned ones do whenever they are larger than a block.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .primaries import Primaries

#: Events per sampling block. Changing it changes every sampled event of every seed.
BLOCK_EVENTS = 1000


class BlockSource(Protocol):
    def primaries(self, rng: np.random.Generator, first_event: int, n_events: int) -> Primaries:
        """``n_events`` events drawn from ``rng``."""


def block_rng(seed: int, block: int) -> np.random.Generator:
    """The numpy stream of sampling block ``block`` of a run with seed ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(block, 0)))


def draw_events(source: BlockSource, seed: int, first_event: int, n_events: int) -> Primaries:
    """Primaries of events ``first_event .. first_event + n_events - 1`` (renumbered from 0);
    of atoms ``first_event ..`` when the source draws per-atom histories.

    Every block the range touches is drawn whole with :func:`block_rng`, then cut.
    """
    if n_events <= 0:
        raise ValueError(f"draw_events: n_events must be > 0, got {n_events}")
    stop = first_event + n_events
    parts = []
    for block in range(first_event // BLOCK_EVENTS, (stop - 1) // BLOCK_EVENTS + 1):
        start = block * BLOCK_EVENTS
        drawn = source.primaries(block_rng(seed, block), start, BLOCK_EVENTS)
        lo, hi = max(first_event, start), min(stop, start + BLOCK_EVENTS)
        if "atom" in drawn.extra:  # whole atoms: the events of atoms lo .. hi - 1
            atom_of_event = drawn.extra["atom"][drawn.event_offsets()[:-1]]
            a, b = np.searchsorted(atom_of_event, [lo, hi], side="left")
            parts.append(drawn.select_events(int(a), int(b)))
        else:
            parts.append(drawn.select_events(lo - start, hi - start))
    return parts[0] if len(parts) == 1 else Primaries.concatenate(parts)
