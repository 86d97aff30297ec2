"""A worker process: builds the Geant4 application once, then runs chunks from a queue.

Messages to the parent (tuples on ``results``):
``("ready", info)``, ``("start", chunk)``, ``("progress", n_events)``,
``("done", chunk)``, ``("error", chunk or None, exception class name, message)``.
"""

from __future__ import annotations

import os
import traceback
from dataclasses import dataclass
from pathlib import Path

from ..config import RunConfig
from ..errors import Score4Error
from ..output import write_chunk
from .runtime import PhysicsChoice
from .seeds import chunk_geant4_seed, chunk_rng


@dataclass(frozen=True)
class Chunk:
    index: int
    first_event: int
    n_events: int


@dataclass(frozen=True)
class WorkerSpec:
    config: RunConfig
    choice: PhysicsChoice
    seed: int
    parts_dir: Path
    fingerprint: str


def chunk_path(parts_dir: Path, index: int) -> Path:
    return Path(parts_dir) / f"chunk-{index:06d}.h5"


def run_chunk(sim, spec: WorkerSpec, chunk: Chunk, progress=None) -> Path:
    """Sample, track and write one chunk; return the chunk file."""
    primaries = sim.source.primaries(chunk_rng(spec.seed, chunk.index), chunk.first_event, chunk.n_events)
    scores = sim.run(primaries, chunk_geant4_seed(spec.seed, chunk.index), progress=progress)
    path = chunk_path(spec.parts_dir, chunk.index)
    write_chunk(path, chunk.first_event, sim.volumes, scores, primaries, spec.fingerprint)
    return path


def worker_main(spec: WorkerSpec, tasks, results) -> None:
    """Entry point of a worker process."""
    from .simulation import Simulation
    from .runtime import geant4_version

    log = Path(spec.parts_dir) / f"geant4-{os.getpid()}.log"
    chunk = None
    try:
        sim = Simulation(spec.config, spec.choice, log_path=log)
        results.put(("ready", {"geant4_version": geant4_version(sim.g4), "removed_processes": sim.removed_processes}))
        while (chunk := tasks.get()) is not None:
            results.put(("start", chunk.index))
            run_chunk(sim, spec, chunk, progress=lambda n: results.put(("progress", n)))
            results.put(("done", chunk.index))
    except Score4Error as err:
        results.put(("error", getattr(chunk, "index", None), type(err).__name__, str(err)))
    except BaseException as err:  # report, then let the parent decide; never hang it
        detail = "".join(traceback.format_exception_only(type(err), err)).strip()
        results.put(("error", getattr(chunk, "index", None), type(err).__name__, detail))
