"""Run one function in a fresh spawned process and return its result (the tests' one helper).

Geant4 keeps global state (volume and material stores, the run manager) and pytest never imports
it: a test that needs Geant4 calls a function of a ``tests/helpers/g4_*.py`` module (or a
module-level function of its own) here, once, in a new interpreter, and gets its (picklable)
return value. The child inherits the parent's ``sys.path``, on which pytest put ``tests/``.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any


def run_in_spawned_process(fn: Callable[..., Any], *args: Any, timeout: float | None = None) -> Any:
    """``fn(*args)`` in a fresh spawned process; its exception is raised here."""
    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        return pool.submit(fn, *args).result(timeout=timeout)
