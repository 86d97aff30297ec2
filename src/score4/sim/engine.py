"""Run a configuration: plan chunks, drive worker processes, merge their files.

The calling process never imports Geant4. Workers (spawned processes) build the Geant4
application and write one file per finished chunk into ``<out>.parts/``; the engine merges
them into ``<out>`` at the end and removes the parts. An interrupted run leaves its finished
chunks in place for ``resume=True``.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing as mp
import os
import platform
import queue
import re
import shutil
import sys
import time
from collections import Counter
from datetime import datetime, timezone
from importlib.metadata import version
from pathlib import Path

import h5py
import numpy as np
from tqdm import tqdm

from .. import __version__
from ..config import RunConfig, config_to_dict
from ..errors import ConfigError, Score4Error
from ..output import merge_chunks
from ..scene import build_scene
from ..source.build import make_source
from .runtime import resolve_physics
from .worker import Chunk, WorkerSpec, chunk_path, worker_main

_ERRORS = {cls.__name__: cls for cls in (ConfigError, Score4Error)}


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
    starts = range(0, n_events, chunk_events)
    return [Chunk(i, s, min(chunk_events, n_events - s)) for i, s in enumerate(starts)]


def config_fingerprint(config: RunConfig, seed: int) -> str:
    """Identifies what a chunk file was made from, so resume never mixes runs."""
    text = json.dumps({"config": config_to_dict(config), "seed": seed}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _finished_chunks(parts: Path, chunks: list[Chunk], fingerprint: str) -> set[int]:
    done = set()
    for c in chunks:
        path = chunk_path(parts, c.index)
        if path.exists():
            with h5py.File(path, "r") as f:
                if f.attrs.get("first_event") == c.first_event and f.attrs.get("fingerprint") == fingerprint:
                    done.add(c.index)
    return done


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


def run(
    config: RunConfig,
    out: str | Path,
    *,
    overwrite: bool = False,
    jobs: int = 1,
    resume: bool = False,
    progress: bool = True,
    echo=None,
) -> Path:
    """Simulate ``config`` and write the results to ``out``; return ``out``.

    ``echo(str)`` receives one-line notices (physics warning, where the log is).
    """
    out = Path(out)
    echo = echo or (lambda msg: print(msg, file=sys.stderr))
    check_output_path(out, overwrite)
    seed = config.run.seed
    if jobs < 1:
        raise ConfigError(f"--jobs: must be at least 1, got {jobs}")
    choice = resolve_physics(config.physics.mode, needs_decay=config.source.nuclide is not None)
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
    parts.mkdir(exist_ok=True)
    for stale in parts.glob("*.partial"):
        stale.unlink()
    done = _finished_chunks(parts, chunks, fingerprint) if resume else set()
    todo = [c for c in chunks if c.index not in done]
    jobs = min(jobs, max(1, len(todo)))
    started = time.time()
    total = sum(c.n_events for c in chunks)
    already = sum(c.n_events for c in chunks if c.index in done)
    try:
        info = _execute(WorkerSpec(config, choice, seed, parts, fingerprint), todo, jobs, total, already, progress)
    except BaseException:
        if not any(parts.glob("chunk-*.h5")):  # nothing worth resuming: leave no trace
            shutil.rmtree(parts, ignore_errors=True)
        raise
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
        "jobs": jobs,
        "wall_time_s": round(time.time() - started, 3),
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "host": platform.node(),
        "geant4_warnings": _geant4_warnings(parts),
    }
    merge_chunks([chunk_path(parts, c.index) for c in chunks], out, record)
    log = _collect_logs(parts, out)
    shutil.rmtree(parts)
    echo(f"Geant4 output: {log}")
    return out


def _execute(spec: WorkerSpec, todo: list[Chunk], jobs: int, total: int, already: int, show: bool) -> dict:
    """Run ``todo`` on ``jobs`` worker processes; return the first worker's ready info."""
    if not todo:
        return {}
    ctx = mp.get_context("spawn")
    tasks, results = ctx.Queue(), ctx.Queue()
    for c in todo:
        tasks.put(c)
    for _ in range(jobs):
        tasks.put(None)
    workers = [ctx.Process(target=worker_main, args=(spec, tasks, results), daemon=True) for _ in range(jobs)]
    for w in workers:
        w.start()
    info: dict = {}
    remaining = {c.index for c in todo}
    bar = tqdm(total=total, initial=already, unit="ev", disable=not show or None, mininterval=0.5, file=sys.stderr)
    failures: list[str] = []
    try:
        while remaining and not failures:
            try:
                msg = results.get(timeout=0.5)
            except queue.Empty:
                if not any(w.is_alive() for w in workers) and results.empty():
                    failures.append(
                        f"worker processes exited unexpectedly (see Geant4's output in {spec.parts_dir}/geant4-*.log); "
                        f"chunks not finished: {sorted(remaining)}"
                    )
                continue
            kind = msg[0]
            if kind == "ready":
                info = info or msg[1]
            elif kind == "progress":
                bar.update(msg[1])
            elif kind == "done":
                remaining.discard(msg[1])
            elif kind == "error":
                _, index, cls, text = msg
                if cls in _ERRORS:  # bad input: say it as it is, like any other input error
                    raise _ERRORS[cls](text)
                where = f"chunk {index}" if index is not None else "worker start-up"
                failures.append(f"{where} failed: {cls}: {text}")
    except KeyboardInterrupt:
        raise Score4Error("run: interrupted; finished chunks are kept, continue with --resume") from None
    finally:
        bar.close()
        for w in workers:
            if w.is_alive():
                w.terminate()
            w.join(timeout=5)
    if failures:
        raise Score4Error("run: " + "; ".join(failures) + " (finished chunks are kept; fix and use --resume)")
    return info
