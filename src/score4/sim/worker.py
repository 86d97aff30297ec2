"""A worker process: builds the Geant4 application once, then runs the chunks the parent sends.

Each worker talks to the parent over its own duplex pipe (no shared queue, so a worker that
dies can never leave a shared lock held):

- parent -> worker: a :class:`Chunk` to run, or ``None`` to finish;
- worker -> parent: ``("ready", info)``, ``("progress", n_events)``, ``("done", chunk index)``,
  ``("library", "start" | "done", what, text)`` (a TRIM library being built),
  ``("error", chunk index or None, exception class name, message)``. After an error the worker
  exits: a Geant4 application that failed half-way through a chunk is not reused.

A worker ignores Ctrl-C (the parent handles it and stops the workers) and exits on its own when
the parent process dies, so a killed run leaves no orphans.

Test hook (fault tests only): with the environment variable
``SCORE4_TEST_CRASH_CHUNK=<i>[,<j>...]``, the process that starts chunk ``i`` dies at once with
``os._exit(70)``, as a segfault or an out-of-memory kill would. It works the same in local and Dask
workers.
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing as mp
import os
import signal
import threading
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import Score4Error, Score4Warning

if TYPE_CHECKING:  # imported where used: a spawned worker imports them with gc off
    import numpy as np

    from score4.runner.run_plan import RunPlan

    from ..source.primaries import Primaries

CRASH_HOOK = "SCORE4_TEST_CRASH_CHUNK"


@dataclass(frozen=True)
class Chunk:
    """Events ``first_event .. first_event + n_events - 1`` of a run, simulated as one piece
    (atoms, when the source draws per-atom histories: a chain with implantation)."""

    index: int
    first_event: int
    n_events: int


@dataclass(frozen=True)
class WorkerSpec:
    """Everything a worker needs to build the application and run chunks of one run: the run
    plan (resolved, to a local and to a Dask worker: :func:`score4.runner.run_plan.worker_pickle`)
    and where chunk files go."""

    plan: RunPlan
    parts_dir: Path

    @property
    def seed(self) -> int:
        return self.plan.seed

    @property
    def fingerprint(self) -> str:
        return self.plan.fingerprint


def chunk_path(parts_dir: Path, index: int) -> Path:
    """The file of finished chunk ``index`` in a run's parts folder."""
    return Path(parts_dir) / f"chunk-{index:06d}.h5"


def simulate_chunk(
    sim, spec: WorkerSpec, chunk: Chunk, progress=None, stop: threading.Event | None = None
) -> tuple[Primaries, dict[str, np.ndarray]]:
    """Sample and track one chunk; return its primaries and {quantity: (n_events, n_volumes) array}.

    The random streams depend only on the run seed and the event indices
    (:mod:`score4.runner.seeds`), so a chunk gives the same result in any process, and an event
    the same result in any chunking. Setting ``stop`` (another thread) ends the chunk after
    its current event with :class:`score4.errors.RunCancelled`.
    """
    if str(chunk.index) in os.environ.get(CRASH_HOOK, "").split(","):
        os._exit(70)  # test hook, see the module docstring
    from score4.runner.seeds import atom_event_geant4_seeds, event_geant4_seeds

    from ..source.primaries import atom_histories

    primaries = sim.source.events(spec.seed, chunk.first_event, chunk.n_events)
    if atom_histories(primaries):  # the chunk is atoms: seeds by atom and event of the atom
        g4_seeds = atom_event_geant4_seeds(
            spec.seed, primaries.extra["atom"][primaries.event_offsets()[:-1]]
        )
    else:
        g4_seeds = event_geant4_seeds(spec.seed, chunk.first_event, chunk.n_events)
    scores = sim.run(primaries, g4_seeds, progress=progress, stop=stop)
    return sim.drop_lost(primaries, scores)


def run_chunk(sim, spec: WorkerSpec, chunk: Chunk, progress=None) -> Path:
    """Sample, track and write one chunk (atomically); return the chunk file."""
    from score4.runner.output import write_chunk

    primaries, scores = simulate_chunk(sim, spec, chunk, progress)
    path = chunk_path(spec.parts_dir, chunk.index)
    write_chunk(
        path,
        chunk.first_event,
        sim.volumes,
        scores,
        primaries,
        spec.fingerprint,
        columns=sim.event_columns(),
        counts=sim.run_counts(),
        steps=sim.step_table(),
    )
    return path


def ready_info(sim) -> dict:
    """What the run record keeps from a worker's Geant4 application."""
    from ..geometry.masses import volume_records
    from .runtime import geant4_version

    info = {
        "geant4_version": geant4_version(sim.g4),
        "removed_processes": sim.removed_processes,
        "volumes": volume_records(sim.g4, sim.scene, sim.geometry.scoring),
    }
    if sim.heavy_ions is not None:
        info["trim_library_seed"] = sim.heavy_ions.library_seed
    return info


def _exit_with_parent() -> None:
    """End this process when the parent dies (even by SIGKILL): a killed run leaves no orphans."""
    parent = mp.parent_process()
    if parent is None:
        return

    def watch() -> None:
        parent.join()
        os._exit(1)

    threading.Thread(target=watch, name="score4-parent-watch", daemon=True).start()


def worker_main(spec: WorkerSpec | bytes, conn) -> None:
    """Entry point of a local worker process; ``conn`` is its end of the pipe to the parent.

    ``spec`` may come pickled (bytes): then the plan is rebuilt here, after the garbage
    collector is switched off, and not while the process unpickles its arguments.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    warnings.simplefilter("ignore", Score4Warning)  # the parent has shown them already
    _exit_with_parent()
    # No garbage collection while the application is set up: the imports, the plan and the
    # Geant4 build make many objects that all stay alive, and the collector's passes over them
    # find nothing (cyclic garbage made meanwhile is collected once the worker is ready).
    gc.disable()
    chunk = None
    try:
        try:
            if isinstance(spec, bytes):
                import pickle

                spec = pickle.loads(spec)
            assert isinstance(spec, WorkerSpec)
            from ..ions.trim_library import set_build_listener
            from .simulation import Simulation

            set_build_listener(
                lambda phase, what, text: _report(conn, ("library", phase, what, text))
            )
            log = Path(spec.parts_dir) / f"geant4-{os.getpid()}.log"
            sim = Simulation(spec.plan, log_path=log)
        finally:
            gc.enable()
        conn.send(("ready", ready_info(sim)))
        while (chunk := conn.recv()) is not None:
            run_chunk(sim, spec, chunk, progress=lambda n: conn.send(("progress", n)))
            conn.send(("done", chunk.index))
            chunk = None
    except (EOFError, BrokenPipeError):  # the parent has gone: nobody to report to
        return
    except Score4Error as err:
        _report(conn, ("error", getattr(chunk, "index", None), type(err).__name__, str(err)))
    except BaseException as err:  # noqa: BLE001 report, then let the parent decide; never hang it
        detail = "".join(traceback.format_exception_only(type(err), err)).strip()
        _report(conn, ("error", getattr(chunk, "index", None), type(err).__name__, detail))


def _report(conn, message: tuple) -> None:
    with contextlib.suppress(OSError, EOFError):  # the parent is gone: nobody left to tell
        conn.send(message)
