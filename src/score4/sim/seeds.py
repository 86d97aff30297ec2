"""Independent random streams per chunk, derived from one run seed.

Chunk ``i`` always gets the same streams whatever the number of chunks or workers, so the
same seed and chunk size reproduce a run exactly, serial or parallel.
"""

from __future__ import annotations

import numpy as np


def chunk_rng(seed: int, index: int) -> np.random.Generator:
    """numpy Generator for sampling the primaries of chunk ``index``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index, 0)))


def chunk_geant4_seed(seed: int, index: int) -> int:
    """Seed for Geant4's engine (MixMax) for chunk ``index``: a positive 31-bit integer."""
    word = np.random.SeedSequence(seed, spawn_key=(index, 1)).generate_state(1, np.uint32)[0]
    return int(word) % (2**31 - 1) + 1
