"""Run a configuration: plan chunks, run them on an executor, merge their files.

The calling process never imports Geant4. An *executor* runs the chunks elsewhere: local
worker processes (:class:`LocalProcesses`, the default) or a Dask cluster
(:class:`score4.sim.dask_backend.DaskExecutor`, ``cluster=``). Every finished chunk becomes one
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
import hashlib
import json
import multiprocessing as mp
import os
import platform
import re
import shutil
import signal
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Iterator
from datetime import datetime, timezone
from importlib.metadata import version
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any, Protocol

import h5py
import numpy as np
from tqdm import tqdm

from .. import __version__, errors
from ..config import RunConfig, config_to_dict
from ..errors import ConfigError, Score4Error
from ..files import atomic_output
from ..output import merge_chunks
from ..scene import build_scene
from ..source.build import make_source, needs_radioactive_decay
from .conservation import check_chunk_files
from .runtime import resolve_physics
from .worker import Chunk, WorkerSpec, check_free_space, chunk_path, worker_main

# Errors that workers report by class name and that the engine raises again as they are.
_ERRORS = {
    cls.__name__: cls
    for cls in vars(errors).values()
    if isinstance(cls, type) and issubclass(cls, Score4Error)
}
MAX_FAILED_CHUNKS = 3
_INFO_FILE = "worker-info.json"

# An executor event: ("ready", info) | ("progress", n_events) | ("done", index)
# | ("failed", index or None, error class name, message)
Event = tuple


class Executor(Protocol):
    """Where chunks run. Implementations: :class:`LocalProcesses`, ``dask_backend.DaskExecutor``.

    ``execute(spec, todo)`` is a generator that runs the chunks ``todo`` and yields events:

    - ``("ready", info)``: a worker has built the Geant4 application (``info`` goes into the run
      record: ``geant4_version``, ``removed_processes``);
    - ``("progress", n_events)``: more events are done (for the progress bar);
    - ``("done", index)``: the file of chunk ``index`` is complete in ``spec.parts_dir``;
    - ``("failed", index, error_class_name, message)``: chunk ``index`` failed (``index`` is
      ``None`` when a worker could not start).

    Closing the generator early (the engine stops the run, or Ctrl-C) must stop all work.
    """

    description: str

    def execute(self, spec: WorkerSpec, todo: list[Chunk]) -> Iterator[Event]: ...


def check_output_path(out: Path, overwrite: bool) -> None:
    """Refuse outputs that cannot be written, or that would replace a file unasked."""
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise ConfigError(f"--out: folder {str(folder)!r} does not exist (create it first)")
    if not os.access(folder, os.W_OK):
        raise ConfigError(f"--out: folder {str(folder)!r} is not writable")
    if out.exists() and not overwrite:
        raise ConfigError(f"--out: {str(out)!r} already exists; use --overwrite to replace it")
    if out.is_dir():
        raise ConfigError(f"--out: {str(out)!r} is a folder, not a file name")


def plan_chunks(n_events: int, chunk_events: int) -> list[Chunk]:
    """Split ``n_events`` into chunks of ``chunk_events`` (the last one may be shorter)."""
    starts = range(0, n_events, chunk_events)
    return [Chunk(i, s, min(chunk_events, n_events - s)) for i, s in enumerate(starts)]


def config_fingerprint(config: RunConfig, seed: int) -> str:
    """Identifies what a chunk file was made from, so resume never mixes runs."""
    text = json.dumps({"config": config_to_dict(config), "seed": seed}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def make_executor(cluster: Any, jobs: int, echo) -> Executor:
    """The executor for ``cluster``: ``None`` = local processes, else Dask (see :func:`run`)."""
    if cluster is None:
        return LocalProcesses(jobs)
    from .dask_backend import DaskExecutor

    return DaskExecutor(cluster, jobs, echo=echo)


def run(
    config: RunConfig,
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

    Parameters
    ----------
    config
        The validated run configuration.
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
        ``echo(str)`` receives one-line notices (physics warning, reduced jobs, how to resume,
        where Geant4's log is); default: print to stderr.
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
    KeyboardInterrupt
        Ctrl-C or SIGTERM; finished chunks are kept for ``resume`` and ``echo`` says so.
    """
    out = Path(out)
    echo = echo or (lambda msg: print(msg, file=sys.stderr))
    check_output_path(out, overwrite)
    seed = config.run.seed
    if jobs < 1:
        raise ConfigError(f"--jobs: must be at least 1, got {jobs}")
    choice = resolve_physics(config.physics.mode, needs_decay=needs_radioactive_decay(config))
    # Build the scene and draw one event here: bad surfaces, files and constraints fail now, not in a worker.
    scene = build_scene(config)
    make_source(config, scene).primaries(np.random.default_rng(0), 0, 1)
    if choice.warning:
        echo(f"warning: {choice.warning}")
    chunks = plan_chunks(config.run.events, config.run.chunk_events)
    fingerprint = config_fingerprint(config, seed)
    parts = out.with_name(out.name + ".parts")
    if parts.exists() and not resume:
        raise ConfigError(
            f"--out: unfinished run parts found in {str(parts)!r}; continue that run with --resume, "
            f"or delete the folder to start again"
        )
    done = (
        _finished_chunks(parts, chunks, fingerprint, echo) if resume and parts.exists() else set()
    )
    todo = [c for c in chunks if c.index not in done]
    if done:
        echo(
            f"resume: {len(done)} of {len(chunks)} chunks already finished in {parts}; running the other {len(todo)}"
        )
    workers = min(jobs, max(1, len(todo)))
    if todo and jobs > len(todo):
        echo(
            f"notice: --jobs {jobs} but only {len(todo)} chunk(s) to run (run.chunk_events = "
            f"{config.run.chunk_events}); using {workers} worker(s). Lower run.chunk_events to use more."
        )
    executor = make_executor(
        cluster, workers, echo
    )  # before creating anything: a bad --cluster leaves no trace
    parts.mkdir(exist_ok=True)
    for stale in parts.glob("*.partial"):  # temporary files of writers that were killed
        stale.unlink()
    started = time.time()
    spec = WorkerSpec(config, choice, seed, parts, fingerprint)
    total = sum(c.n_events for c in chunks)
    try:
        with _sigterm_as_interrupt():
            info = _run_chunks(
                executor, spec, todo, total, total - sum(c.n_events for c in todo), progress
            )
    except KeyboardInterrupt:
        kept = _count_chunk_files(parts, chunks)
        if kept:
            echo(
                f"run interrupted: {kept} of {len(chunks)} chunks are finished and kept in {parts}; "
                f"run the same command again with --resume to finish the run"
            )
        else:
            shutil.rmtree(parts, ignore_errors=True)
            echo("run interrupted before any chunk finished; nothing kept")
        raise
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
            f"{err}; {kept} of {len(chunks)} chunks are finished and kept in {parts} (Geant4's output: "
            f"geant4-*.log there); run the same command again with --resume to retry the failed and "
            f"missing chunks"
        ) from None
    except BaseException:
        if not _count_chunk_files(parts, chunks):
            shutil.rmtree(parts, ignore_errors=True)
        raise
    info = info or _recall_info(parts)
    files = [chunk_path(parts, c.index) for c in chunks]
    balance = _energy_balance(files, choice.decay, echo)
    record = {
        "config": config_to_dict(config),
        "patch_maps": {layer.name: layer.patch_map.to_dict() for layer in scene.layers},
        "seed": seed,
        "physics_mode": choice.mode,
        "physics_requested": choice.requested,
        "physics_lacks": choice.lacks,
        "missing_data_sets": list(choice.missing_data),
        "removed_processes": info.get("removed_processes", []),
        "score4_version": __version__,
        "geant4_pybind_version": version("geant4_pybind"),
        "geant4_version": info.get("geant4_version", ""),
        "n_events": config.run.events,
        "n_chunks": len(chunks),
        "chunk_events": config.run.chunk_events,
        "jobs": workers,
        "backend": executor.description,
        "resumed_chunks": len(done),
        "wall_time_s": round(time.time() - started, 3),
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "host": platform.node(),
        "geant4_warnings": _geant4_warnings(parts),
        **balance,
    }
    try:
        check_free_space(out, sum(f.stat().st_size for f in files))
        merge_chunks(files, out, record)
    except Score4Error as err:
        raise Score4Error(
            f"{err}; all {len(chunks)} chunks are finished and kept in {parts}: fix the cause (e.g. free disk "
            f"space) and run the same command again with --resume to merge them"
        ) from None
    log = _collect_logs(parts, out)
    shutil.rmtree(parts)
    echo(f"Geant4 output: {log}")
    return out


def _run_chunks(
    executor: Executor, spec: WorkerSpec, todo: list[Chunk], total: int, already: int, show: bool
) -> dict:
    """Run ``todo`` on ``executor``; return a worker's ready info; raise on failed chunks."""
    if not todo:
        return {}
    info: dict = {}
    finished: set[int] = set()
    failures: dict[int, str] = {}
    bar = tqdm(
        total=total,
        initial=already,
        unit="ev",
        disable=not show or None,
        mininterval=0.5,
        file=sys.stderr,
    )
    try:
        with contextlib.closing(executor.execute(spec, todo)) as events:
            for event in events:
                kind = event[0]
                if kind == "ready" and not info:
                    info = event[1]
                    _remember_info(spec.parts_dir, info)
                elif kind == "progress":
                    bar.update(event[1])
                elif kind == "done":
                    finished.add(event[1])
                elif kind == "failed":
                    _, index, cls, text = event
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
    missing = [c.index for c in todo if c.index not in finished and c.index not in failures]
    if failures or missing:
        said = list(failures.values())
        if len(failures) >= MAX_FAILED_CHUNKS and missing:
            said.append(f"stopped after {len(failures)} failed chunks")
        if missing:
            said.append(f"{len(missing)} chunk(s) not run: {_ranges(missing)}")
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

    def execute(self, spec: WorkerSpec, todo: list[Chunk]) -> Iterator[Event]:
        ctx = mp.get_context("spawn")
        pending = deque(todo)
        workers = [_LocalWorker(ctx, spec) for _ in range(min(self.jobs, len(todo)))]
        replacements = len(todo)
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
                        workers.append(_LocalWorker(ctx, spec))
        finally:
            for w in workers:
                w.terminate()
            for w in workers:
                w.join()


class _LocalWorker:
    """The parent's side of one local worker process."""

    def __init__(self, ctx, spec: WorkerSpec) -> None:
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=worker_main, args=(spec, child), daemon=True)
        self.process.start()
        child.close()
        self.chunk: Chunk | None = None  # the chunk it runs now
        self.ready = False  # has built the application
        self.reported = False  # has reported an error (and exits)

    def handle_messages(self, pending: deque) -> Iterator[Event]:
        try:
            while not self.conn.closed and self.conn.poll():
                msg = self.conn.recv()
                kind = msg[0]
                if kind == "ready":
                    self.ready = True
                    yield msg
                    self._send_next(pending)
                elif kind == "progress":
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

    def _send_next(self, pending: deque) -> None:
        self.chunk = pending.popleft() if pending else None
        try:
            self.conn.send(self.chunk)
        except OSError:  # died meanwhile: the chunk never started
            if self.chunk is not None:
                pending.appendleft(self.chunk)
            self.chunk = None

    def handle_exit(self, pending: deque) -> Iterator[Event]:
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


def _finished_chunks(parts: Path, chunks: list[Chunk], fingerprint: str, echo) -> set[int]:
    """Indices of chunks whose files in ``parts`` are complete and come from this very run."""
    done, foreign, damaged = set(), [], []
    for c in chunks:
        path = chunk_path(parts, c.index)
        if not path.exists():
            continue
        try:
            with h5py.File(path, "r") as f:
                same = (
                    f.attrs.get("fingerprint") == fingerprint
                    and f.attrs.get("first_event") == c.first_event
                )
                ids = f["events/event_id"][()]
        except (OSError, KeyError):
            damaged.append(c.index)
            continue
        if not same:
            foreign.append(c.index)
        elif not np.array_equal(ids, c.first_event + np.arange(c.n_events)):
            damaged.append(c.index)
        else:
            done.add(c.index)
    if foreign:
        echo(
            f"resume: chunk files {_ranges(foreign)} in {parts} come from another configuration or seed; "
            f"they are run again"
        )
    if damaged:
        echo(
            f"resume: chunk files {_ranges(damaged)} in {parts} are damaged or incomplete; they are run again"
        )
    return done


def _energy_balance(files: list[Path], decay: bool, echo) -> dict:
    """Run-record entries of the energy-conservation check (:mod:`score4.sim.conservation`)."""
    if decay:  # radioactive decay releases energy that no primary carried
        return {"energy_check": "skipped: radioactive decay adds energy to the primaries'"}
    balance = check_chunk_files(files)
    if balance.warning:
        echo(f"warning: {balance.warning}")
    return {
        "energy_check": "event deposit (all volumes) <= primaries' kinetic energy + 1 eV",
        "energy_violations": balance.violations,
        "energy_max_excess_MeV": balance.max_excess_mev,
    }


def _count_chunk_files(parts: Path, chunks: list[Chunk]) -> int:
    return sum(chunk_path(parts, c.index).exists() for c in chunks)


def _remember_info(parts: Path, info: dict) -> None:
    """Keep a worker's ready info in the parts folder: a resume with nothing left to run needs it."""
    with contextlib.suppress(Score4Error), atomic_output(parts / _INFO_FILE) as tmp:
        tmp.write_text(json.dumps(info))


def _recall_info(parts: Path) -> dict:
    try:
        return json.loads((parts / _INFO_FILE).read_text())
    except (OSError, ValueError):
        return {}


def _geant4_warnings(parts: Path) -> list[str]:
    """Distinct G4Exception warnings in the workers' logs, with counts."""
    found: Counter[str] = Counter()
    for log in sorted(parts.glob("geant4-*.log")):
        lines = log.read_text(errors="replace").splitlines()
        for i, line in enumerate(lines):
            m = re.search(r"G4Exception : (\S+)", line)
            if m:
                issuer = lines[i + 1].split(":", 1)[-1].strip() if i + 1 < len(lines) else ""
                message = lines[i + 2].strip() if i + 2 < len(lines) else ""
                found[f"{m.group(1)} ({issuer}): {message}"] += 1
    return [f"{text} [x{n}]" for text, n in found.most_common()]


def _collect_logs(parts: Path, out: Path) -> Path:
    log = out.with_name(out.stem + ".geant4.log")
    with open(log, "w") as dst:
        for src in sorted(parts.glob("geant4-*.log")):
            dst.write(f"===== {src.name} =====\n{src.read_text(errors='replace')}")
    return log
