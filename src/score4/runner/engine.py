"""Run a configuration: plan, execute or resume the chunks on an executor, merge their files.

:func:`run` is three steps: **plan** (:func:`score4.runner.run_plan.plan_run` resolves the
configuration once; :func:`preflight` checks it by drawing the first events), **execute or
resume** (:func:`prepare` cuts the chunks and finds those a resume reuses, :func:`execute` runs
the others; the workers receive the :class:`~score4.runner.run_plan.RunPlan` in a
:class:`~score4.sim.worker.WorkerSpec`), **merge** (:func:`run_record` makes the
:class:`~score4.runner.run_record.RunRecord`, :func:`merge` writes the results file).

The calling process never imports Geant4. An *executor* runs the chunks elsewhere: local
worker processes (:class:`LocalProcesses`, the default) or a Dask cluster
(:class:`score4.runner.dask_backend.DaskExecutor`, ``cluster=``). Every finished chunk becomes one
file in ``<out>.parts/``, written atomically (a half-written file never carries a chunk's
name); the engine merges them into ``<out>`` at the end and removes the parts folder.

Faults:

- Interrupted (Ctrl-C, SIGTERM, a kill): the finished chunk files stay; ``resume=True``
  reuses every chunk file made from the same configuration and seed (the fingerprint) and
  runs the others, so the merged result is the one an uninterrupted run gives.
- A chunk whose worker crashes or raises an unexpected exception is reported by index; the
  other chunks go on (a dead local worker is replaced), and the run ends with an error naming
  the failed chunks, which a resume retries. After ``MAX_FAILED_CHUNKS`` failures the run stops.
- Bad input (:class:`ConfigError`) and faults of the environment (:class:`Score4Error`, such
  as a full disk) stop the run at once; finished chunks are kept.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing as mp
import platform
import re
import shutil
import signal
import sys
import threading
import time
import warnings
from collections import Counter, deque
from collections.abc import Generator, Iterable, Iterator, Sequence, Sized
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib.metadata import version
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any, Protocol

import h5py
import numpy as np

from score4 import errors
from score4.common import limits
from score4.common.schema import input_paths
from score4.inputs.config import RunConfig, config_to_dict
from score4.runner.conservation import check_chunk_files
from score4.runner.normalisation import run_normalisation
from score4.runner.output import chunk_counts, merge_chunks
from score4.runner.progress import progress_bar
from score4.runner.run_plan import RunPlan, plan_run, worker_pickle
from score4.runner.run_record import RunRecord
from score4.runner.seeds import BLOCK_EVENTS
from score4.sim.worker import Chunk, WorkerSpec, chunk_path, worker_main
from score4.version import package_version
from score4.world.scene import Scene
from score4.world.walls import warn_rays_in_walls

from ..errors import ConfigError, Score4Error
from ..files import atomic_output, check_free_space, check_output_file
from ..source.vertex_file import read_vertex_file

# Errors that workers report by class name and that the engine raises again as they are.
_ERRORS = {
    cls.__name__: cls
    for cls in vars(errors).values()
    if isinstance(cls, type) and issubclass(cls, Score4Error)
}
MAX_FAILED_CHUNKS = 3
_INFO_FILE = "worker-info.json"
_PLAN_FILE = "plan.json"  # the chunk size of the run the parts folder belongs to

# An executor event: ("ready", info) | ("progress", n_events) | ("done", index)
# | ("failed", index or None, error class name, message)
Event = tuple


class Executor(Protocol):
    """Where chunks run. Implementations: :class:`LocalProcesses`, ``dask_backend.DaskExecutor``.

    ``execute(spec, todo)`` is a generator that runs the chunks ``todo`` and yields events:

    - ``("ready", info)``: a worker has built the Geant4 application (``info`` goes into the run
      record: ``geant4_version``, ``removed_processes``, ``trim_library_seed``);
    - ``("progress", n_events)``: more events are done (for the progress bar);
    - ``("library", "start" | "done", what, text)``: a worker starts or ends building the TRIM
      library ``what`` (the text says about how long; the time is left out of the events' rate);
    - ``("done", index)``: the file of chunk ``index`` is complete in ``spec.parts_dir``;
    - ``("failed", index, error_class_name, message)``: chunk ``index`` failed (``index`` is
      ``None`` when a worker could not start).

    Closing the generator early (the engine stops the run, or Ctrl-C) must stop all work.
    """

    description: str

    def execute(self, spec: WorkerSpec, todo: Iterable[Chunk]) -> Generator[Event, None, None]: ...


class ChunkPlan(Sequence[Chunk]):
    """The chunks of a run of ``n_events`` events, ``size`` events each (the last may be shorter).

    Lazy: chunk ``i`` is computed when asked for, so planning 10^11 events costs nothing.
    """

    def __init__(self, n_events: int, size: int) -> None:
        if n_events < 1 or size < 1:
            raise ValueError(f"ChunkPlan: need n_events >= 1 and size >= 1, got {n_events}, {size}")
        self.n_events, self.size = int(n_events), int(size)

    def __len__(self) -> int:
        return -(-self.n_events // self.size)

    def __getitem__(self, index):  # int only; a slice of a plan is not needed
        if isinstance(index, slice):
            raise TypeError("ChunkPlan: slicing is not supported")
        n = len(self)
        index = index + n if index < 0 else index
        if not 0 <= index < n:
            raise IndexError(f"chunk {index} of {n}")
        first = index * self.size
        return Chunk(index, first, min(self.size, self.n_events - first))

    def __iter__(self) -> Iterator[Chunk]:
        return (self[i] for i in range(len(self)))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ChunkPlan) and (self.n_events, self.size) == (
            other.n_events,
            other.size,
        )

    def __repr__(self) -> str:
        return f"ChunkPlan(n_events={self.n_events}, size={self.size})"

    def remaining(self, done: set[int]) -> Iterator[Chunk]:
        """The chunks whose index is not in ``done``, in order, one at a time."""
        return (self[i] for i in range(len(self)) if i not in done)


def chunk_size(n_events: int, chunk_events: int, jobs: int = 1) -> int:
    """Events per chunk: enough chunks for ``jobs`` workers, at most ``chunk_events`` each.

    ``ceil(n_events / jobs)`` events, rounded up to whole sampling blocks
    (:data:`~score4.runner.seeds.BLOCK_EVENTS`) when that still makes at least ``jobs`` chunks,
    and capped by ``chunk_events`` (``run.chunk_events``). So 5000 events on 2 workers are 2
    chunks (3000 + 2000 events) and each worker gets one; there are fewer chunks than workers
    only in runs of fewer than ``jobs * (jobs - 1)`` events. The result of a run does not depend on
    the chunk size (:mod:`score4.runner.seeds`).
    """
    jobs = max(1, jobs)
    size = -(-n_events // jobs)
    whole_blocks = -(-size // BLOCK_EVENTS) * BLOCK_EVENTS
    if size > BLOCK_EVENTS and -(-n_events // whole_blocks) >= jobs:
        size = whole_blocks
    return max(1, min(chunk_events, size))


def plan_chunks(n_events: int, chunk_events: int, jobs: int = 1) -> ChunkPlan:
    """The chunks of a run of ``n_events`` events (see :func:`chunk_size`)."""
    return ChunkPlan(n_events, chunk_size(n_events, chunk_events, jobs))


def make_executor(cluster: Any, jobs: int, echo) -> Executor:
    """The executor for ``cluster``: ``None`` = local processes, else Dask (see :func:`run`)."""
    if cluster is None:
        return LocalProcesses(jobs)
    from score4.runner.dask_backend import DaskExecutor

    return DaskExecutor(cluster, jobs, echo=echo)


@dataclass(frozen=True)
class Preflight:
    """What the parent's checks before a run found out (:func:`preflight`)."""

    unit: str  # "events", or "atoms" for per-atom histories
    rows_per_unit: float  # primaries per event (per atom for per-atom histories)


@dataclass
class Execution:
    """The chunks of a run and which of them are to run (:func:`prepare`), then what ran."""

    parts: Path
    chunks: ChunkPlan
    done: set[int]  # finished chunks a resume reuses
    workers: int
    backend: str = ""
    info: dict = field(default_factory=dict)  # a worker's ready info
    started: float = 0.0


def run(
    config: RunConfig | RunPlan,
    out: str | Path,
    *,
    overwrite: bool = False,
    jobs: int = 1,
    resume: bool = False,
    progress: bool = True,
    echo=None,
    cluster: Any = None,
) -> Path:
    """Simulate ``config`` and write the results to ``out``; return ``out``.

    Three steps: plan (:func:`~score4.runner.run_plan.plan_run` and :func:`preflight`, in this
    process), execute or resume (:func:`prepare`, :func:`execute`: the chunks on workers), merge
    (:func:`merge`: the chunk files and the :class:`~score4.runner.run_record.RunRecord`).

    Parameters
    ----------
    config
        The validated run configuration, or its :class:`~score4.runner.run_plan.RunPlan`.
    out
        Results file (HDF5). Chunks are kept in ``<out>.parts/`` until the merge.
    overwrite
        Replace an existing ``out``.
    jobs
        Worker processes: local ones, or the workers of a local Dask cluster. Never more than
        the number of chunks to run (a notice says so).
    resume
        Reuse the finished chunks of an interrupted or failed run with the same configuration
        and seed from ``<out>.parts/``, and run only the others.
    progress
        Show a progress bar on stderr.
    echo
        ``echo(str)`` receives one-line notices (reduced jobs, resumed chunks, where Geant4's
        log is); default: print to stderr. Warnings (lite physics) are
        :class:`~score4.errors.Score4Warning` warnings.
    cluster
        ``None``: local processes. ``"dask"``: a local Dask cluster of ``jobs`` worker
        processes. ``"tcp://host:port"`` (any Dask address): an existing Dask scheduler. A
        ``distributed.Client`` is used as it is. See docs/cluster.md.

    Raises
    ------
    ConfigError
        Bad input, found before or during the run.
    Score4Error
        The run failed (failed chunks, full disk, ...); finished chunks are kept for ``resume``.
    RunInterrupted
        Ctrl-C or SIGTERM (a ``KeyboardInterrupt``); finished chunks are kept for ``resume``
        and the message says so.
    """
    out = Path(out)
    echo = echo or (lambda msg: print(msg, file=sys.stderr))
    given = config.config if isinstance(config, RunPlan) else config
    check_output_file(out, overwrite, "--out", input_paths(given))
    if jobs < 1:
        raise ConfigError(f"--jobs: must be at least 1, got {jobs}")
    plan = config if isinstance(config, RunPlan) else plan_run(config)
    checked = preflight(plan)
    job = prepare(plan, out, jobs, resume, checked, echo)
    if progress:  # Geant4 takes seconds to start: say so before the bar's first line
        echo(f"run: geometry and source ready; starting Geant4 in {job.workers} worker(s)")
    executor = make_executor(
        cluster, job.workers, echo
    )  # before creating anything: a bad --cluster leaves no trace
    execute(plan, job, executor, progress, out)
    record = run_record(plan, job)
    merge(out, job, record, echo)
    return out


def preflight(plan: RunPlan) -> Preflight:
    """The parent's checks before a run: draw the first events (bad surfaces, files,
    constraints and vertices outside the world fail now, not in a worker), the memory of the
    merge, the source's normalisation, hand-made rays on block walls, lite-physics warnings."""
    config, scene, source = plan.config, plan.scene, plan.source
    if source is None:
        raise ValueError("preflight: the plan has no source (made with source=False)")
    drawn = min(config.run.events, BLOCK_EVENTS)  # events, or atoms for per-atom histories
    sample = source.events(plan.seed, 0, drawn)
    unit = f"{source.unit}s"
    rows_per_unit = len(sample) / (drawn if unit == "atoms" else sample.n_events)
    check_run_memory(config, len(sample) / sample.n_events, sample.n_events / drawn)
    run_normalisation(config, scene)  # the source's area or mass: any problem shows now
    if config.source.vertices is not None and scene.layers:  # hand-made rays: beams on walls?
        rays = read_vertex_file(config.source.vertices)
        text = warn_rays_in_walls(scene, rays.position, rays.direction)
        if text:
            warnings.warn(text, errors.Score4Warning, stacklevel=3)
    if plan.physics.warning:
        warnings.warn(plan.physics.warning, errors.Score4Warning, stacklevel=3)
    return Preflight(unit, rows_per_unit)


def prepare(
    plan: RunPlan, out: Path, jobs: int, resume: bool, checked: Preflight, echo
) -> Execution:
    """The chunks of the run, those a resume reuses from ``<out>.parts/``, and the workers."""
    n_events = plan.config.run.events
    parts = out.with_name(out.name + ".parts")
    if parts.exists() and not resume:
        raise ConfigError(
            f"--out: unfinished run parts found in {str(parts)!r}; continue that run with "
            "--resume, or delete the folder to start again"
        )
    resuming = resume and parts.exists()
    # A resumed run keeps the chunks of the run it continues, whatever --jobs is now.
    chunks = (resuming and _recall_plan(parts, n_events)) or plan_chunks(
        n_events, plan.config.run.chunk_events, jobs
    )
    done = _finished_chunks(parts, chunks, plan.fingerprint, echo) if resuming else set()
    limits.check_memory(  # every worker holds one chunk's primaries and scores
        jobs * chunks.size * (limits.PRIMARY_BYTES * checked.rows_per_unit + 64),
        f"{jobs} worker(s) holding chunks of {chunks.size} {checked.unit}",
        "run.chunk_events",
        "use a smaller run.chunk_events",
    )
    n_todo = len(chunks) - len(done)
    if done:
        echo(
            f"resume: {len(done)} of {len(chunks)} chunks already finished in {parts}; running the "
            f"other {n_todo}"
        )
    workers = min(jobs, max(1, n_todo))
    if n_todo and jobs > n_todo:
        echo(
            f"notice: --jobs {jobs} but only {n_todo} chunk(s) to run "
            f"({_chunks_text(chunks, done)}); "
            f"using {workers} worker(s)"
        )
    return Execution(parts, chunks, done, workers)


def execute(plan: RunPlan, job: Execution, executor: Executor, progress: bool, out: Path) -> None:
    """Run the chunks not yet done on ``executor`` into ``job.parts``; on any failure keep the
    finished chunks for a resume (or leave no trace when none finished) and raise."""
    parts, chunks = job.parts, job.chunks
    job.backend = executor.description
    job.started = time.time()
    try:  # from the first file on: a Ctrl-C here also leaves nothing half-made
        parts.mkdir(exist_ok=True)
        _remember_plan(parts, chunks)
        for stale in parts.glob("*.partial"):  # temporary files of writers that were killed
            stale.unlink()
        spec = WorkerSpec(plan, parts)
        with _sigterm_as_interrupt():
            info = _run_chunks(executor, spec, chunks, job.done, progress)
    except KeyboardInterrupt:
        kept = _count_chunk_files(parts, chunks)
        if kept:
            said = (
                f"run interrupted: {kept} of {len(chunks)} chunks are finished and kept in "
                f"{parts}; run the same command again with --resume to finish the run"
            )
        else:
            shutil.rmtree(parts, ignore_errors=True)
            said = "run interrupted before any chunk finished; nothing kept"
        raise errors.RunInterrupted(said) from None
    except Score4Error as err:
        kept = _count_chunk_files(parts, chunks)
        if (
            not kept
        ):  # nothing worth resuming: leave no trace, but keep Geant4's output of a real fault
            if not isinstance(err, ConfigError) and any(parts.glob("geant4-*.log")):
                err = type(err)(f"{err} (Geant4's output: {_collect_logs(parts, out)})")
            shutil.rmtree(parts, ignore_errors=True)
            raise err from None
        raise type(err)(
            f"{err}; {kept} of {len(chunks)} chunks are finished and kept in {parts} (Geant4's "
            "output: geant4-*.log there); run the same command again with --resume to retry the "
            "failed and missing chunks"
        ) from None
    except BaseException:
        if not _count_chunk_files(parts, chunks):
            shutil.rmtree(parts, ignore_errors=True)
        raise
    job.info = info or _recall_info(parts)


def _map_meshes(scene: Scene) -> dict[str, Any] | None:
    """Per rough layer of height maps: the tolerance (um; 0 the exact mesh) and the number of top
    facets of each variant's mesh (score4.surface.simplify); None without height maps."""
    out = {
        layer.name: {
            "tolerance_um": [round(s.mesh_tolerance * 1e3, 9) for s in layer.variants],
            "top_facets": [s.top_mesh.n_faces for s in layer.variants],
        }
        for layer in scene.layers
        if any(s.heightmap is not None for s in layer.variants)
    }
    return out or None


def run_record(plan: RunPlan, job: Execution) -> RunRecord:
    """The run record of a finished run: the plan, what the workers reported, sums over the
    chunk files (energy balance, untracked photons, ion counts), Geant4's warnings."""
    config, scene, choice, info = plan.config, plan.scene, plan.physics, job.info
    files = [chunk_path(job.parts, c.index) for c in job.chunks]
    balance = _energy_balance(files, choice.decay)
    exceptions = _geant4_exceptions(job.parts)
    _warn_broken_solids(exceptions)
    return RunRecord(
        config=config_to_dict(config),
        patch_maps={layer.name: layer.patch_map.to_dict() for layer in scene.layers},
        seed=plan.seed,
        physics_mode=choice.mode,
        physics_requested=choice.requested,
        physics_lacks=choice.lacks,
        missing_data_sets=list(choice.missing_data),
        removed_processes=info.get("removed_processes", []),
        trim_library_seed=info.get("trim_library_seed"),  # runs with a TRIM replay
        rough_shares={layer.name: layer.rough_share for layer in scene.layers},
        map_meshes=_map_meshes(scene),
        gdml_files=scene.model.files if scene.model is not None else [],
        score4_version=package_version(),
        geant4_pybind_version=version("geant4_pybind"),
        geant4_version=info.get("geant4_version", ""),
        **_run_size(plan, files),
        n_chunks=len(job.chunks),
        chunk_events=job.chunks.size,
        jobs=job.workers,
        backend=job.backend,
        resumed_chunks=len(job.done),
        wall_time_s=round(time.time() - job.started, 3),
        created_utc=datetime.now(UTC).isoformat(timespec="seconds"),
        host=platform.node(),
        geant4_warnings=_geant4_warnings(exceptions),
        **_stuck_tracks(exceptions),
        **balance,
        **_untracked_photons(files),
        **_counts(files, plan),
        # contract 1, what the events stand for: volumes (one per scoring column: name, material,
        # density, volume, mass; from the worker's Geant4 world), the sampled area or mass, the
        # decays (score4.runner.normalisation)
        normalisation=run_normalisation(config, scene, volumes=info.get("volumes") or None),
    )


def merge(out: Path, job: Execution, record: RunRecord, echo) -> None:
    """Merge the chunk files into ``out`` with ``record``; collect Geant4's logs beside it and
    remove the parts folder."""
    files = [chunk_path(job.parts, c.index) for c in job.chunks]
    try:
        check_free_space(out, sum(f.stat().st_size for f in files))
        merge_chunks(files, out, record.to_dict())
    except Score4Error as err:
        raise Score4Error(
            f"{err}; all {len(job.chunks)} chunks are finished and kept in {job.parts}: fix the "
            "cause (e.g. free disk space) and run the same command again with --resume to merge "
            "them"
        ) from None
    log = _collect_logs(job.parts, out)
    shutil.rmtree(job.parts)
    echo(f"Geant4 output: {log}")


def check_run_memory(
    config: RunConfig, primaries_per_event: float, events_per_unit: float = 1.0
) -> None:
    """Refuse a run whose results this machine cannot merge (the merge holds them in memory).

    ``events_per_unit``: events per ``run.events`` unit (per atom for per-atom histories)."""
    n = config.run.events
    columns = 2 + len(config.targets) * (3 if config.output.track_length else 1)
    events = int(np.ceil(n * events_per_unit))
    limits.check_memory(
        limits.results_bytes(events, columns, primaries_per_event),
        f"merging the results of {events} events",
        "run.events",
        "split it into runs of fewer events with different --seed values",
    )


def _run_chunks(
    executor: Executor, spec: WorkerSpec, chunks: ChunkPlan, done: set[int], show: bool
) -> dict:
    """Run the chunks not in ``done`` on ``executor``; return a worker's ready info; raise on failed
    chunks."""
    n_todo = len(chunks) - len(done)
    if not n_todo:
        return {}
    info: dict = {}
    finished: set[int] = set()
    failures: dict[int, str] = {}
    # per-atom histories (a chain with implantation): run.events and the progress count atoms
    unit = "atoms" if spec.plan.per_atom else "events"
    bar = progress_bar(chunks.n_events, sum(chunks[i].n_events for i in done), unit, "run", show)
    told: set[tuple[str, str]] = set()
    try:
        with contextlib.closing(executor.execute(spec, chunks.remaining(done))) as events:
            for event in events:
                kind = event[0]
                if kind == "ready" and not info:
                    info = event[1]
                    _remember_info(spec.parts_dir, info)
                elif kind == "progress":
                    bar.update(event[1])
                elif kind == "library":  # a worker builds a TRIM library (see trim_library)
                    _, phase, what, text = event
                    if (phase, what) not in told:  # workers may build the same one
                        told.add((phase, what))
                        if show:
                            bar.write(f"run: {text}")
                        elif phase == "start" and sys.stderr.isatty():
                            # even quiet, at a terminal: a one-time wait of up to minutes
                            print(f"score4: run: {text}", file=sys.stderr, flush=True)
                    if phase == "done":
                        bar.unpause()  # the time it took is not part of the events' rate
                elif kind == "done":
                    finished.add(event[1])
                elif kind == "failed":
                    _, index, cls, text = event
                    if cls == "WorkerDied":
                        text += _last_exception_text(spec.parts_dir, text)
                    if cls in _ERRORS:  # bad input or a fault of the environment: stop now
                        where = (
                            ""
                            if index is None or cls == "ConfigError"
                            else f"run: chunk {index} failed: "
                        )
                        raise _ERRORS[cls](where + text)
                    if index is None:
                        raise Score4Error(f"run: a worker process failed to start: {cls}: {text}")
                    failures[index] = f"chunk {index} failed ({cls}: {text})"
                    if len(failures) >= MAX_FAILED_CHUNKS:
                        break
    finally:
        bar.close()
    ran = finished | set(failures)
    missing = n_todo - len(ran)
    if failures or missing:
        said = list(failures.values())
        if len(failures) >= MAX_FAILED_CHUNKS and missing:
            said.append(f"stopped after {len(failures)} failed chunks")
        if missing:
            said.append(
                f"{missing} chunk(s) not run: {_complement_ranges(len(chunks), done | ran)}"
            )
        raise Score4Error("run: " + "; ".join(said))
    return info


class LocalProcesses:
    """Runs chunks on spawned worker processes on this machine (the default executor).

    The parent hands out one chunk at a time per worker, so it always knows which chunk a
    worker runs: a worker that dies fails exactly that chunk, and a new worker takes over
    the chunks still waiting.
    """

    def __init__(self, jobs: int) -> None:
        self.jobs = jobs
        self.description = f"local processes ({jobs})"

    def execute(self, spec: WorkerSpec, todo: Iterable[Chunk]) -> Generator[Event, None, None]:
        ctx = mp.get_context("spawn")
        pending = _Pending(todo)
        if not pending:
            return
        n = len(todo) if isinstance(todo, Sized) else self.jobs
        # pickled once, resolved and without pydantic models (run_plan.worker_pickle): a worker
        # unpickles it with the garbage collector off and rebuilds nothing
        blob = worker_pickle(spec)
        workers = [_LocalWorker(ctx, blob) for _ in range(min(self.jobs, n))]
        # a worker that dies with a chunk is replaced while chunks wait (the engine stops the run
        # after MAX_FAILED_CHUNKS failures; one that dies starting up stops it at once)
        replacements = len(todo) if isinstance(todo, Sized) else float("inf")
        try:
            while workers:
                wait([w.conn for w in workers] + [w.process.sentinel for w in workers], timeout=1.0)
                for w in list(workers):
                    yield from w.handle_messages(pending)
                    if w.process.is_alive():
                        continue
                    yield from w.handle_exit(pending)  # also returns an unstarted chunk to pending
                    workers.remove(w)
                    if (
                        pending and w.ready and replacements > 0
                    ):  # a working worker died: replace it
                        replacements -= 1
                        workers.append(_LocalWorker(ctx, blob))
        finally:
            for w in workers:
                w.terminate()
            for w in workers:
                w.join()


class _Pending:
    """Chunks waiting for a worker, taken lazily from an iterable (never listed in full)."""

    def __init__(self, chunks: Iterable[Chunk]) -> None:
        self._rest = iter(chunks)
        self._front: deque[Chunk] = deque()  # chunks given back, or looked at

    def __bool__(self) -> bool:
        if not self._front:
            nxt = next(self._rest, None)
            if nxt is None:
                return False
            self._front.append(nxt)
        return True

    def popleft(self) -> Chunk:
        if not self:
            raise IndexError("no chunk waiting")
        return self._front.popleft()

    def appendleft(self, chunk: Chunk) -> None:
        self._front.appendleft(chunk)


class _LocalWorker:
    """The parent's side of one local worker process."""

    def __init__(self, ctx, blob: bytes) -> None:
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=worker_main, args=(blob, child), daemon=True)
        self.process.start()
        child.close()
        self.chunk: Chunk | None = None  # the chunk it runs now
        self.ready = False  # has built the application
        self.reported = False  # has reported an error (and exits)

    def handle_messages(self, pending: _Pending) -> Iterator[Event]:
        try:
            while not self.conn.closed and self.conn.poll():
                msg = self.conn.recv()
                kind = msg[0]
                if kind == "ready":
                    self.ready = True
                    yield msg
                    self._send_next(pending)
                elif kind in ("progress", "library"):
                    yield msg
                elif kind == "done":
                    self.chunk = None
                    yield msg
                    self._send_next(pending)
                elif kind == "error":
                    self.chunk, self.reported = None, True
                    yield ("failed", *msg[1:])
        except (EOFError, OSError):  # the worker is gone; handle_exit says how
            pass

    def _send_next(self, pending: _Pending) -> None:
        self.chunk = pending.popleft() if pending else None
        try:
            self.conn.send(self.chunk)
        except OSError:  # died meanwhile: the chunk never started
            if self.chunk is not None:
                pending.appendleft(self.chunk)
            self.chunk = None

    def handle_exit(self, pending: _Pending) -> Iterator[Event]:
        self.join()
        pid, code = self.process.pid, self.process.exitcode
        if self.chunk is not None:
            yield (
                "failed",
                self.chunk.index,
                "WorkerDied",
                f"worker process {pid} died, {_exit_text(code)}",
            )
        elif not self.ready and not self.reported:
            yield (
                "failed",
                None,
                "WorkerDied",
                f"worker process {pid} died during start-up, {_exit_text(code)}",
            )

    def terminate(self) -> None:
        if self.process.is_alive():
            self.process.terminate()

    def join(self) -> None:
        self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(timeout=5)
        self.conn.close()


def _exit_text(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"killed by signal {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _ranges(indices: list[int]) -> str:
    """'0-3, 7, 9-10' for [0, 1, 2, 3, 7, 9, 10]."""
    out, start = [], None
    for i, k in enumerate(indices):
        start = k if start is None else start
        if i + 1 == len(indices) or indices[i + 1] != k + 1:
            out.append(str(k) if k == start else f"{start}-{k}")
            start = None
    return ", ".join(out)


def _complement_ranges(n: int, excluded: set[int]) -> str:
    """:func:`_ranges` of the indices ``0 .. n-1`` not in ``excluded`` (a small set), without
    listing them."""
    out, start = [], 0
    for k in [*sorted(i for i in excluded if 0 <= i < n), n]:
        if k > start:
            out.append(str(start) if k == start + 1 else f"{start}-{k - 1}")
        start = k + 1
    return ", ".join(out)


def _chunks_text(chunks: ChunkPlan, done: set[int]) -> str:
    """Why there are fewer chunks to run than workers."""
    if done:
        return f"{len(done)} of {len(chunks)} chunks are already finished"
    return f"the run has {chunks.n_events} event(s)"


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """During the run, SIGTERM (a batch system's time limit, ``kill``) stops it like Ctrl-C."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _chunk_files(parts: Path, chunks: ChunkPlan) -> dict[int, Path]:
    """{index: file} of the files in ``parts`` named like finished chunks of ``chunks``."""
    found = {}
    for path in parts.glob("chunk-*.h5"):
        m = re.fullmatch(r"chunk-(\d+)\.h5", path.name)
        if m and int(m.group(1)) < len(chunks):
            found[int(m.group(1))] = path
    return found


def _finished_chunks(parts: Path, chunks: ChunkPlan, fingerprint: str, echo) -> set[int]:
    """Indices of chunks whose files in ``parts`` are complete and come from this very run."""
    done, foreign, damaged = set(), [], []
    for index, path in sorted(_chunk_files(parts, chunks).items()):
        c = chunks[index]
        try:
            with h5py.File(path, "r") as f:
                same = (
                    f.attrs.get("fingerprint") == fingerprint
                    and f.attrs.get("first_event") == c.first_event
                )
                ids = f["events/event_id"][()]
                atoms = f.attrs.get("unit") == "atom"
                units = int(f.attrs.get("n_units", -1))
        except (OSError, KeyError):
            damaged.append(c.index)
            continue
        if not same:
            foreign.append(c.index)
        elif atoms:  # per-atom histories: all the chunk's atoms, events numbered from 0
            if units != c.n_events or not np.array_equal(ids, np.arange(len(ids))):
                damaged.append(c.index)
            else:
                done.add(c.index)
        elif not np.array_equal(ids, c.first_event + np.arange(c.n_events)):
            damaged.append(c.index)
        else:
            done.add(c.index)
    if foreign:
        echo(
            f"resume: chunk files {_ranges(foreign)} in {parts} come from another configuration or "
            "seed; they are run again"
        )
    if damaged:
        echo(
            f"resume: chunk files {_ranges(damaged)} in {parts} are damaged or incomplete; they "
            "are run again"
        )
    return done


def _energy_balance(files: list[Path], decay: bool) -> dict:
    """Run-record entries of the energy-conservation check (:mod:`score4.runner.conservation`)."""
    if decay:  # radioactive decay releases energy that no primary carried
        return {"energy_check": "skipped: radioactive decay adds energy to the primaries'"}
    balance = check_chunk_files(files)
    if balance.warning:
        warnings.warn(balance.warning, errors.Score4Warning, stacklevel=4)
    return {
        "energy_check": "event deposit (all volumes) <= primaries' kinetic energy + 1 eV",
        "energy_violations": balance.violations,
        "energy_max_excess_MeV": balance.max_excess_mev,
    }


def _untracked_photons(files: list[Path]) -> dict:
    """Run-record sums of the photon energy lite physics did not track (empty in full mode)."""
    import h5py

    total, events = 0.0, 0
    for path in files:
        with h5py.File(path, "r") as f:
            if "untracked_gamma_energy" not in f["events"]:
                return {}  # full physics (or a chunk written without the count)
            values = f["events/untracked_gamma_energy"][()]
            total += float(values.sum())
            events += int((values > 0).sum())
    return {"untracked_gamma_energy_MeV": total, "untracked_gamma_events": events}


def _run_size(plan: RunPlan, files: list[Path]) -> dict:
    """``n_events``; with per-atom histories (a chain with implantation) ``run.events`` counts
    atoms (``n_atoms``) and ``n_events`` is the events their decays made."""
    if not plan.per_atom:
        return {"n_events": plan.config.run.events}
    events = 0
    for path in files:
        with h5py.File(path, "r") as f:
            events += len(f["events/event_id"])
    return {"n_atoms": plan.config.run.events, "n_events": events}


def _counts(files: list[Path], plan: RunPlan) -> dict:
    """Run-record counts added up over the chunks: ``intercepted_ions``,
    ``reinjected_ions`` and ``replay_pushes`` (runs with the TRIM replay), ``implantation``
    (chains with it)."""
    counts = chunk_counts(files)
    out = {}
    if plan.config.physics.heavy_ions == "trim":
        keys = ("intercepted_ions", "reinjected_ions", "replay_pushes")
        out = {k: int(counts.get(k, 0)) for k in keys}
    if plan.per_atom:
        out["implantation"] = counts.get("implantation", {})
    return out


def _count_chunk_files(parts: Path, chunks: ChunkPlan) -> int:
    return len(_chunk_files(parts, chunks))


def _remember_plan(parts: Path, chunks: ChunkPlan) -> None:
    """Keep the chunk size in the parts folder: a resume with another --jobs keeps the same
    chunks."""
    with contextlib.suppress(Score4Error), atomic_output(parts / _PLAN_FILE) as tmp:
        tmp.write_text(json.dumps({"n_events": chunks.n_events, "chunk_size": chunks.size}))


def _recall_plan(parts: Path, n_events: int) -> ChunkPlan | None:
    """The chunk plan stored in ``parts`` for a run of ``n_events`` events, or None."""
    try:
        plan = json.loads((parts / _PLAN_FILE).read_text())
        if int(plan["n_events"]) == n_events:
            return ChunkPlan(n_events, int(plan["chunk_size"]))
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def _remember_info(parts: Path, info: dict) -> None:
    """Keep a worker's ready info in the parts folder: a resume with nothing left to run needs
    it."""
    with contextlib.suppress(Score4Error), atomic_output(parts / _INFO_FILE) as tmp:
        tmp.write_text(json.dumps(info))


def _recall_info(parts: Path) -> dict:
    try:
        return json.loads((parts / _INFO_FILE).read_text())
    except (OSError, ValueError):
        return {}


def _geant4_exceptions(parts: Path) -> list[tuple[str, str, str]]:
    """(code, issuer, message) of every G4Exception in the workers' logs, in log order."""
    found = []
    for log in sorted(parts.glob("geant4-*.log")):
        found += _exceptions_in(log.read_text(errors="replace"))
    return found


def _last_exception_text(parts: Path, text: str) -> str:
    """ "; Geant4's fatal exception: ..." with the last fatal G4Exception (one that aborts the
    process; warnings are not the cause) in the log of the worker ``text`` names
    (``worker process <pid> died``), or "" when there is none."""
    m = re.search(r"worker process (\d+)", text)
    logs = [parts / f"geant4-{m.group(1)}.log"] if m else sorted(parts.glob("geant4-*.log"))
    found = []
    for log in logs:
        with contextlib.suppress(OSError):
            found += _exceptions_in(log.read_text(errors="replace"), fatal_only=True)
    if not found:
        return ""
    code, issuer, message = found[-1]
    return f"; Geant4's fatal exception: {code} ({issuer}): {message}"


def _exceptions_in(text: str, fatal_only: bool = False) -> list[tuple[str, str, str]]:
    """(code, issuer, message) of every G4Exception in one log text, in order; with
    ``fatal_only``, those Geant4 marks fatal (an ``EEEE`` start line, not ``WWWW``)."""
    found = []
    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = re.search(r"G4Exception : (\S+)", line)
        if not m:
            continue
        start = next(
            (lines[j] for j in range(i - 1, max(i - 4, -1), -1) if "-START" in lines[j]), ""
        )
        if fatal_only and "EEEE" not in start:
            continue
        issuer = lines[i + 1].split(":", 1)[-1].strip() if i + 1 < len(lines) else ""
        message = lines[i + 2].strip() if i + 2 < len(lines) else ""
        found.append((m.group(1), issuer, message))
    return found


def _geant4_warnings(exceptions: list[tuple[str, str, str]]) -> list[str]:
    """Distinct G4Exceptions with counts, most frequent first."""
    found = Counter(f"{code} ({issuer}): {message}" for code, issuer, message in exceptions)
    return [f"{text} [x{n}]" for text, n in found.most_common()]


#: Geant4's navigator codes for a track that makes no progress: after 10 zero-length steps it
#: pushes the track 1e-7 mm (GeomNav1002, a warning); after 25 it kills the track and aborts the
#: whole event (GeomNav0003). Rays lying exactly in the shared walls of neighbouring volumes
#: (block cut planes and corners, patch cell walls) do this: docs/tiling.md#rays-on-block-walls.
STUCK_PUSHED, STUCK_ABORTED = "GeomNav1002", "GeomNav0003"


def _warn_broken_solids(exceptions: list[tuple[str, str, str]]) -> None:
    """Warn when Geant4 refused a facet or found a tessellated solid open: that solid has a hole
    and tracks leak through it (Geant4 only prints a warning and builds it anyway)."""
    broken = sorted(
        {msg for _, issuer, msg in exceptions if "too narrow" in msg or "holes in the" in msg}
    )
    if broken:
        warnings.warn(
            f"Geant4 built a tessellated solid with a hole ({'; '.join(broken[:3])}): tracks "
            "may leak through it and the results are not exact; the run record's "
            "geant4_warnings lists each (please report it with the input)",
            errors.Score4Warning,
            stacklevel=4,
        )


def _stuck_tracks(exceptions: list[tuple[str, str, str]]) -> dict:
    """Run-record counts of stuck tracks Geant4 pushed or killed; warns when events were aborted."""
    counts = Counter(code for code, _, _ in exceptions)
    aborted = counts[STUCK_ABORTED]
    if aborted:
        warnings.warn(
            f"Geant4 killed {aborted} stuck track(s) and aborted their events ({STUCK_ABORTED}: no "
            "progress for 25 steps on a volume boundary, e.g. a ray exactly along the walls or "
            "corners of rough-surface blocks or patch cells); those events lack deposits. Offset "
            "such beams from the cell grid (docs/tiling.md#rays-on-block-walls); the count is the "
            "run record's stuck_events_aborted",
            errors.Score4Warning,
            stacklevel=4,
        )
    return {"stuck_tracks_pushed": counts[STUCK_PUSHED], "stuck_events_aborted": aborted}


def _collect_logs(parts: Path, out: Path) -> Path:
    log = out.with_name(out.stem + ".geant4.log")
    with atomic_output(log) as tmp, open(tmp, "w") as dst:
        dst.writelines(
            f"===== {src.name} =====\n{src.read_text(errors='replace')}"
            for src in sorted(parts.glob("geant4-*.log"))
        )
    return log
