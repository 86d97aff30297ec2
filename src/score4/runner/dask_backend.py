"""Run chunks on a Dask cluster (``distributed``): a local one, or an existing scheduler.

Used by :func:`score4.runner.engine.run` with ``cluster="dask"`` (a ``LocalCluster`` of ``jobs``
worker processes, one thread each), ``cluster="tcp://host:port"`` (any scheduler address) or
``cluster=<distributed.Client>``. Install with ``pip install 'score4[cluster]'``.

How it works (see docs/cluster.md):

- The chunks, their seeds and their files are the same as with local processes, so a run gives
  identical results on either backend, and ``--resume`` works the same way.
- The plan goes to the workers resolved, as to local worker processes
  (:func:`score4.runner.run_plan.worker_pickle`): pickled once, scattered once to every worker,
  and unpickled once per worker process and run; the chunk tasks name it. So a worker rebuilds
  no scene and imports neither pydantic nor the configuration's models.
- Each Dask worker *process* builds the Geant4 application once and keeps it for the next
  chunks (a module-level cache keyed by the configuration, :func:`setup_key`). Geant4 allows one
  run manager per process and must be driven from the thread that built it, so all Geant4 work
  of a process runs on one dedicated thread; a worker with several threads therefore still runs
  one chunk at a time (start workers with ``--nthreads 1``). Workers that hold another run's
  set-up are restarted before a run (this needs a nanny, the default of ``dask worker`` and
  dask-jobqueue); one run at a time per set of workers.
- A worker returns each chunk's arrays to the client, which writes the chunk file (atomically)
  into the parts folder. So the parts folder and the results need to be on the client's disk
  only. The input files that the configuration names (measured surfaces, vertex files, depth
  tables), the Geant4 data sets (full physics) and score4 itself must be available on every
  worker, at the same paths.
- Geant4's console output of a worker process goes to a file in the worker's temporary folder;
  every chunk brings the new lines back, and the client appends them to
  ``geant4-dask-<host>-<pid>.log`` in the parts folder.
- A cancelled chunk (Ctrl-C, a failure, the client gone) stops on its worker within about
  :data:`CANCEL_POLL_S` plus one event: Dask cannot interrupt a running task, so the task
  watches its own state on the worker and, once the scheduler has cancelled it, asks the
  Geant4 thread to end the run after the current event (:meth:`Simulation.run`'s ``stop``).
  The worker keeps its Geant4 set-up for the next chunks.
- A worker process that dies is restarted by its nanny and Dask retries the chunk on another
  worker (``distributed.scheduler.allowed-failures`` times); then the chunk fails with
  ``KilledWorker`` and the run reports it like a local crash.
"""

from __future__ import annotations

import contextlib
import gc
import hashlib
import json
import logging
import os
import re
import socket
import tempfile
import threading
import uuid
import warnings
from collections.abc import Generator, Iterable
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from score4.sim.worker import Chunk, WorkerSpec, chunk_path, ready_info, simulate_chunk

from ..errors import ConfigError, Score4Error, Score4Warning
from ..source.primaries import Primaries
from .output import write_chunk

INSTALL_HINT = "pip install 'score4[cluster]'"
SUBMIT_WINDOW = 256  # chunks submitted ahead of the finished ones
CANCEL_POLL_S = 0.1  # how often a running chunk task looks whether it was cancelled
_ADDRESS = re.compile(r"[a-z][a-z0-9+.-]*://\S+")


def require_distributed():
    """Import and return ``distributed``, or say how to install it."""
    try:
        import distributed
    except ImportError as err:
        raise Score4Error(
            "--cluster: the Dask backend needs the 'distributed' package, which is not installed "
            f"({err}); install it with: {INSTALL_HINT}"
        ) from None
    return distributed


@dataclass
class ChunkOutput:
    """What a Dask worker sends back for one chunk."""

    index: int
    first_event: int
    volumes: list[str]
    scores: dict[str, np.ndarray]
    primaries: Primaries
    info: dict
    log: str
    worker: str
    columns: dict[str, np.ndarray] = field(default_factory=dict)  # more per-event columns
    counts: dict = field(default_factory=dict)  # for the run record (Simulation.run_counts)
    steps: dict | None = None  # output.steps (Simulation.step_table)


class DaskExecutor:
    """Runs chunks as Dask tasks (the :class:`score4.runner.engine.Executor` interface).

    Parameters
    ----------
    cluster
        ``"dask"`` for a new local cluster of ``jobs`` worker processes (closed after the run),
        a scheduler address such as ``"tcp://host:8786"``, or a ``distributed.Client``.
    jobs
        Worker processes of a local cluster; not used with an existing scheduler.
    echo
        Receives one-line notices.
    """

    def __init__(self, cluster: Any, jobs: int, echo=print) -> None:
        distributed = require_distributed()
        self.jobs, self.echo = jobs, echo
        self.client, self.address = None, None
        if isinstance(cluster, distributed.Client):
            self.client = cluster
            self.description = f"dask {cluster.scheduler.address}"
        elif cluster == "dask":
            self.description = f"dask local cluster ({jobs} workers)"
        elif isinstance(cluster, str) and _ADDRESS.fullmatch(cluster):
            self.address = cluster
            self.description = f"dask {cluster}"
        else:
            raise ConfigError(
                f"--cluster: {cluster!r} is neither 'dask' (a local Dask cluster of --jobs "
                "workers) nor a Dask scheduler address such as tcp://host:8786"
            )
        if self.address and jobs > 1:
            echo(
                f"notice: --jobs {jobs} does not apply with --cluster {cluster}: the scheduler's "
                "workers run the chunks"
            )

    def execute(self, spec: WorkerSpec, todo: Iterable[Chunk]) -> Generator[tuple, None, None]:
        from distributed import as_completed

        client, own_client, cluster = self.client, False, None
        futures: set = set()  # submitted and not yet finished
        try:
            if client is None:
                client, cluster = self._connect()
                own_client = True
            setup = setup_key(spec)
            self._free_workers(client, setup)
            # the plan resolved, pickled once and sent once to every worker (as to a local
            # worker: run_plan.worker_pickle), not pickled again with every task; under a key of
            # its own per run (hash=False), not shared with an earlier run of the same plan
            from .run_plan import worker_pickle

            plan = client.scatter(worker_pickle(spec), broadcast=True, hash=False)
            run_id = uuid.uuid4().hex[:8]
            by_key = {}
            # submitted a window at a time: a huge run lists no chunks up front
            waiting = iter(todo)

            def submit_next() -> None:
                c = next(waiting, None)
                if c is None:
                    return
                fut = client.submit(
                    run_chunk_task,
                    setup,
                    plan.key,
                    plan,
                    c,
                    key=f"score4-chunk-{c.index:06d}-{run_id}",
                    priority=-c.index,
                )
                futures.add(fut)
                by_key[fut.key] = c
                running.add(fut)

            running = as_completed()
            for _ in range(SUBMIT_WINDOW):
                submit_next()
            announced = False
            for fut in running:
                submit_next()
                chunk = by_key.pop(fut.key)
                futures.discard(fut)
                try:
                    result: ChunkOutput = fut.result()
                except Exception as exc:  # noqa: BLE001 any task failure: report its chunk and why
                    yield ("failed", chunk.index, *_describe(exc))
                    continue
                finally:
                    fut.release()
                if not announced:
                    announced = True
                    yield ("ready", result.info)
                try:
                    _store(spec, result)
                except Score4Error as err:  # e.g. the client's disk is full
                    yield ("failed", chunk.index, type(err).__name__, str(err))
                    continue
                yield ("progress", chunk.n_events)
                yield ("done", chunk.index)
        finally:
            if futures and client is not None:
                with contextlib.suppress(Exception):
                    client.cancel(list(futures), force=True)
            if own_client and client is not None:
                with contextlib.suppress(Exception):
                    client.close()
            if cluster is not None:
                with contextlib.suppress(Exception):
                    cluster.close()

    def _connect(self):
        from distributed import Client, LocalCluster

        if self.address is None:
            cluster = LocalCluster(
                n_workers=self.jobs,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                silence_logs=logging.ERROR,  # any free port
            )
            return Client(cluster), cluster
        try:  # waits up to distributed.comm.timeouts.connect (Dask configuration; 30 s by default)
            return Client(self.address), None
        except (OSError, TimeoutError) as err:
            raise Score4Error(
                f"--cluster: cannot connect to the Dask scheduler at {self.address}: {err}"
            ) from None

    def _free_workers(self, client, key: str) -> None:
        """Restart the workers whose process holds another run's Geant4 set-up."""
        held = client.run(held_setup_key)
        others = [addr for addr, k in held.items() if k not in (None, key)]
        if others:
            self.echo(
                f"notice: restarting {len(others)} Dask worker(s) that hold another run's Geant4 "
                "set-up"
            )
            try:
                client.restart_workers(others)
            except Exception as err:  # noqa: BLE001 whatever stops the restart ends the run here
                raise Score4Error(
                    f"--cluster: could not restart Dask workers {others} that hold another run's "
                    f"Geant4 set-up ({err}); start the workers with a nanny, or restart them by "
                    "hand"
                ) from None


def _describe(exc: BaseException) -> tuple[str, str]:
    """(error class name, message) of a failed chunk task."""
    name = type(exc).__name__
    if name == "KilledWorker":
        return "WorkerDied", f"the Dask worker processes that ran it died ({exc})"
    return name, str(exc)


def _store(spec: WorkerSpec, result: ChunkOutput) -> None:
    """Write a returned chunk into the parts folder (atomically) and append its Geant4 output."""
    write_chunk(
        chunk_path(spec.parts_dir, result.index),
        result.first_event,
        result.volumes,
        result.scores,
        result.primaries,
        spec.fingerprint,
        columns=result.columns,
        counts=result.counts,
        steps=result.steps,
    )
    if result.log:
        with (
            contextlib.suppress(OSError),
            open(Path(spec.parts_dir) / f"geant4-dask-{result.worker}.log", "a") as f,
        ):
            f.write(result.log)


# ----------------------------------------------------------------- worker side

_held: dict = {}  # the Geant4 set-up of this worker process: key, sim or error, log
_g4_lock = threading.Lock()
_g4_executor: ThreadPoolExecutor | None = None


def setup_key(spec: WorkerSpec) -> str:
    """Identifies the Geant4 set-up a chunk needs (configuration and physics; not the seed).
    Computed by the client (a worker never imports the configuration's models)."""
    from score4.inputs.config import config_to_dict

    text = json.dumps(
        {"config": config_to_dict(spec.plan.config), "physics": asdict(spec.plan.physics)},
        sort_keys=True,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def held_setup_key() -> str | None:
    """The set-up key this worker process holds (run on the workers through ``Client.run``)."""
    return _held.get("key")


def run_chunk_task(setup: str, plan_key: str, blob: bytes, chunk: Chunk) -> ChunkOutput:
    """The Dask task: run one chunk in this worker process, on its Geant4 thread.

    ``blob`` is the run's :class:`WorkerSpec` as :func:`~score4.runner.run_plan.worker_pickle`
    wrote it (scattered to the workers under the key ``plan_key``), ``setup`` its
    :func:`setup_key`.

    While the chunk runs, this (Dask's) thread looks every :data:`CANCEL_POLL_S` whether the
    scheduler has cancelled the task, and then stops the Geant4 run after its current event.
    """
    global _g4_executor
    with _g4_lock:
        if _g4_executor is None:
            _g4_executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="score4-geant4")
    stop = threading.Event()
    cancelled = _cancel_watch()
    running = _g4_executor.submit(_run_chunk_here, setup, plan_key, blob, chunk, stop)
    while True:
        try:
            return running.result(timeout=CANCEL_POLL_S)
        except FutureTimeout:
            if not stop.is_set() and cancelled():
                stop.set()  # the run raises RunCancelled after its current event


def _cancel_watch():
    """A cheap test (a dict look-up) of whether the task running in this thread was cancelled."""
    try:
        from distributed import get_worker

        worker = get_worker()
        key = worker.get_current_task()
    except (ImportError, ValueError, KeyError):  # not in a Dask task (called directly)
        return lambda: False

    def cancelled() -> bool:
        task = worker.state.tasks.get(key)
        return task is None or task.state in ("cancelled", "released", "forgotten")

    return cancelled


def _run_chunk_here(
    setup: str, plan_key: str, blob: bytes, chunk: Chunk, stop: threading.Event
) -> ChunkOutput:
    spec, sim = _simulation(setup, plan_key, blob)
    primaries, scores = simulate_chunk(sim, spec, chunk, stop=stop)
    return ChunkOutput(
        chunk.index,
        chunk.first_event,
        list(sim.volumes),
        scores,
        primaries,
        ready_info(sim),
        _new_log_text(),
        f"{socket.gethostname()}-{os.getpid()}",
        sim.event_columns(),
        sim.run_counts(),
        sim.step_table(),
    )


def _spec(plan_key: str, blob: bytes) -> WorkerSpec:
    """The run's spec, unpickled once per worker process and run (the last one is kept)."""
    if _held.get("plan_key") != plan_key:
        import pickle

        spec = pickle.loads(blob)
        assert isinstance(spec, WorkerSpec)
        _held.update(plan_key=plan_key, spec=spec)
    spec = _held["spec"]
    assert isinstance(spec, WorkerSpec)
    return spec


def _simulation(setup: str, plan_key: str, blob: bytes) -> tuple[WorkerSpec, Any]:
    """The run's spec and this worker process's Geant4 application (built on the first chunk)."""
    key = setup
    if "key" not in _held:
        from score4.sim.simulation import Simulation

        log = Path(tempfile.gettempdir()) / f"score4-geant4-{os.getpid()}.log"
        _held.update(key=key, log=log)
        # no garbage collection while the plan is unpickled and Geant4 set up, as in a local
        # worker (sim.worker.worker_main): the collector's passes over those objects find nothing
        gc.disable()
        try:
            spec = _spec(plan_key, blob)
            with warnings.catch_warnings():  # the client has shown them already
                warnings.simplefilter("ignore", Score4Warning)
                _held["sim"] = Simulation(spec.plan, log_path=log)
        except BaseException as err:
            _held["error"] = err
            raise
        finally:
            gc.enable()
    if _held["key"] != key:
        raise Score4Error(
            "--cluster: this Dask worker process already holds the Geant4 set-up of another run "
            "(Geant4 allows one per process); restart the workers (Client.restart()) or give each "
            "run its own workers"
        )
    if "error" in _held:  # Geant4 may be half set up: never build it twice in one process
        prior = _held["error"]
        raise (
            type(prior)(str(prior))
            if isinstance(prior, Score4Error)
            else Score4Error(
                f"this Dask worker process failed to set up Geant4 before: {type(prior).__name__}: "
                f"{prior}"
            )
        )
    return _spec(plan_key, blob), _held["sim"]


def _new_log_text() -> str:
    """Geant4's console output of this process since the last chunk."""
    try:
        data = _held["log"].read_bytes()
        _held[
            "log"
        ].unlink()  # recreated by the next chunk: no file is left behind in the temporary folder
        return data.decode(errors="replace")
    except OSError:
        return ""
