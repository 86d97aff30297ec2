"""Random streams of a run, derived from its seed alone: prefix-stable and independent of chunking.

- Primaries: drawn in blocks of :data:`~score4.source.event_blocks.BLOCK_EVENTS` events, block ``b``
  from its own numpy stream (:func:`score4.source.event_blocks.block_rng`).
- Geant4: every event reseeds Geant4's engine (MixMax) with its own 63-bit seed derived from
  (run seed, event index) (:func:`event_geant4_seeds`; ``setTheSeed`` costs ~0.2 us). An
  event's tracking therefore depends on nothing but the run seed and its index.

So event ``k`` is the same event, with the same energy deposits, whatever the number of events,
the chunk size, the number of workers or the executor; and the first N events of a run are a
run of N events.

- Per-atom histories (a chain with implantation): the unit is the atom. Event ``j`` of atom
  ``a`` (its ``j``-th event, in time order) gets the seed of :func:`atom_event_geant4_seeds`:
  atom ``a``'s word of the same block streams, mixed with ``j``; so an atom's events are the
  same whatever chunk holds the atom.
- TRIM: the trajectory libraries of a run (:mod:`score4.ions.trim_library`) are built with the
  TRIM seed :func:`library_trim_seed` of the run seed, so runs with other seeds replay other
  histories; ``score4 range --compare-srim`` runs its TRIM reference with
  :func:`reference_trim_seed`, never equal to the library seed of the same run.
"""

from __future__ import annotations

import numpy as np

from score4.source.event_blocks import BLOCK_EVENTS, block_rng

__all__ = [
    "BLOCK_EVENTS",
    "atom_event_geant4_seeds",
    "block_rng",
    "event_geant4_seeds",
    "library_trim_seed",
    "reference_trim_seed",
]

#: TRIM's seeds are integers in [1, TRIM_SEED_MAX] (lunasrim; 0 means TRIM's own default).
TRIM_SEED_MAX = 2147483562
_LIBRARY_STREAM = 2
_REFERENCE_STREAM = 3


def event_geant4_seeds(seed: int, first_event: int, n_events: int) -> np.ndarray:
    """(n_events,) positive 63-bit Geant4 seeds of events ``first_event ..``, as Python-int-able
    uint64.

    The seeds of block ``b`` come from ``SeedSequence(seed, spawn_key=(b, 1))``.
    """
    stop = first_event + n_events
    parts = []
    for block in range(first_event // BLOCK_EVENTS, (stop - 1) // BLOCK_EVENTS + 1):
        start = block * BLOCK_EVENTS
        words = np.random.SeedSequence(seed, spawn_key=(block, 1)).generate_state(
            BLOCK_EVENTS, np.uint64
        )
        words = np.maximum(words >> np.uint64(1), np.uint64(1))  # 1 .. 2**63 - 1
        parts.append(
            words[max(first_event, start) - start : min(stop, start + BLOCK_EVENTS) - start]
        )
    return np.concatenate(parts) if parts else np.zeros(0, np.uint64)


def atom_event_geant4_seeds(seed: int, atom: np.ndarray) -> np.ndarray:
    """Geant4 seeds of the events of per-atom histories, ``atom``: the atom of each event
    (non-decreasing, all events of each atom present, in order).

    The seed of event ``j`` of atom ``a`` is a SplitMix64 mix of ``a``'s word of
    :func:`event_geant4_seeds` (the same streams, indexed by atom) and ``j``.
    """
    atom = np.asarray(atom, dtype=np.int64)
    if not len(atom):
        return np.zeros(0, np.uint64)
    first = int(atom[0])
    words = event_geant4_seeds(seed, first, int(atom[-1]) - first + 1)[atom - first]
    starts = np.r_[True, atom[1:] != atom[:-1]]
    index = np.arange(len(atom)) - np.maximum.accumulate(np.where(starts, np.arange(len(atom)), 0))
    z = words + (index.astype(np.uint64) + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return np.maximum(z >> np.uint64(1), np.uint64(1))


def _trim_seed(seed: int, stream: int) -> int:
    word = np.random.SeedSequence(int(seed), spawn_key=(stream,)).generate_state(1, np.uint64)[0]
    return 1 + int(word % np.uint64(TRIM_SEED_MAX))


def library_trim_seed(seed: int) -> int:
    """TRIM seed of the trajectory libraries of a run with seed ``seed`` (1 .. TRIM_SEED_MAX)."""
    return _trim_seed(seed, _LIBRARY_STREAM)


def reference_trim_seed(seed: int) -> int:
    """TRIM seed of an independent reference for a run with seed ``seed`` (``--compare-srim``).

    Drawn from its own stream and never equal to :func:`library_trim_seed` of the same seed,
    so a comparison never replays the histories it is compared with.
    """
    value = _trim_seed(seed, _REFERENCE_STREAM)
    if value == library_trim_seed(seed):
        value = value % TRIM_SEED_MAX + 1
    return value
