"""Importing geant4_pybind safely and capturing Geant4's console output (worker side).

geant4_pybind runs a data-set check at import: without ``GEANT4_DATA_DIR`` it asks on stdin
or, with ``CI=true``, downloads from CERN. score4 always decides the data locations itself
before the import (:func:`score4.runner.physics_choice.prepare_environment`), so neither can
happen. The physics choice itself is made without Geant4, in :mod:`score4.runner.physics_choice`;
this module re-exports its names for the programs that start Geant4.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from score4.runner.physics_choice import (
    LITE_LACKS,
    PhysicsChoice,
    lite_stub_dir,
    prepare_environment,
    resolve_physics,
)

T = TypeVar("T")

__all__ = [
    "LITE_LACKS",
    "PhysicsChoice",
    "geant4_version",
    "import_geant4",
    "in_own_process",
    "lite_stub_dir",
    "prepare_environment",
    "redirect_native_output",
    "resolve_physics",
]


def import_geant4(choice: PhysicsChoice):
    """Import geant4_pybind with the data locations fixed by ``choice``; return the module."""
    prepare_environment(choice)
    import geant4_pybind

    return geant4_pybind


def in_own_process(fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` in a spawned process of its own, for a command that builds Geant4 volumes
    (the overlap check, the world and surface exports): Geant4 keeps every volume it builds in
    process-wide stores that nothing empties, and its GDML reader looks volumes up there by name,
    so two such builds in one process meet. The calling process never imports Geant4; ``fn``
    (a module-level function) and ``args`` are pickled, and its exception is raised here."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        return pool.submit(fn, *args).result()


@contextlib.contextmanager
def redirect_native_output(log_path: Path | None):
    """Send everything written to file descriptors 1 and 2 (Geant4's G4cout/G4cerr) to a log.

    geant4_pybind does not bind G4UIsession, so the console cannot be captured inside Geant4;
    redirecting the descriptors is the reliable way. Yields a text stream on the original
    stderr for progress messages. With ``log_path=None`` nothing is redirected.
    """
    if log_path is None:
        yield sys.stderr
        return
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    console = os.fdopen(os.dup(saved[1]), "w", buffering=1)
    with open(log_path, "ab") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            yield console
        finally:
            libc.fflush(None)
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            console.close()


def geant4_version(g4) -> str:
    """ "11.4.1"-style version of the Geant4 inside geant4_pybind."""
    number = int(g4.G4VERSION_NUMBER)
    return f"{number // 100}.{(number // 10) % 10}.{number % 10}"
