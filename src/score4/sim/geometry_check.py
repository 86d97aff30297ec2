"""``score4 geometry check`` in a process of its own: build a run's world, let Geant4 check it.

Geant4 keeps every solid, logical and physical volume it builds in process-wide stores, and
nothing removes a world from them. A second world built in the same process meets the first:
Geant4's GDML reader looks volumes up by name in those stores, so a second GDML world took the
first world's ``crystal`` and Geant4 then reported overlaps with a box of the earlier world. So
each check builds its world in a spawned process (:func:`score4.sim.runtime.in_own_process`),
as a run's workers do (the plan is sent as to a worker:
:func:`score4.runner.run_plan.worker_pickle`), and the calling process never imports Geant4:
a program may call :func:`check_geometry` (or ``score4.cli.main.main``) any number of times,
each check with its own stores.
"""

from __future__ import annotations

import ctypes
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from score4.geometry.check import OverlapReport
    from score4.runner.run_plan import RunPlan


def _check(blob: bytes, points: int, tolerance: float, max_placements: int, log: str):
    """In the spawned process: build the plan's world and check it (Geant4's output to ``log``;
    progress lines on stderr)."""
    from ..geometry.check import check_placements
    from ..geometry.world import build_world
    from .runtime import import_geant4, redirect_native_output

    plan = pickle.loads(blob)
    g4 = import_geant4(plan.physics)
    with redirect_native_output(Path(log)) as console:
        built = build_world(g4, plan)

        def progress(line: str) -> None:
            console.write(f"  {line}\n")
            console.flush()

        return check_placements(
            built.world,
            points,
            tolerance,
            max_placements,
            layers=plan.scene.layers,
            progress=progress,
            read_log=log_reader(Path(log)),
        )


def log_reader(log: Path) -> Callable[[], str]:
    """A function returning what was written to ``log`` (Geant4's output, redirected there by
    :func:`~score4.sim.runtime.redirect_native_output`) since its last call, C buffers flushed
    first: the overlap reports of one ``CheckOverlaps`` (re-tested by
    :func:`score4.geometry.check.retest_reports`)."""
    libc = ctypes.CDLL(None)
    read = [log.stat().st_size if log.exists() else 0]

    def read_log() -> str:
        libc.fflush(None)
        with open(log, "rb") as fh:
            fh.seek(read[0])
            text = fh.read()
        read[0] += len(text)
        return text.decode(errors="replace")

    return read_log


def check_geometry(
    plan: RunPlan, points: int, tolerance: float, max_placements: int, log: Path
) -> OverlapReport:
    """Build ``plan``'s world in a spawned process and check its placements for overlaps
    (:func:`score4.geometry.check.check_placements`); Geant4's output is appended to ``log``."""
    from score4.runner.run_plan import worker_pickle

    from .runtime import in_own_process

    blob = worker_pickle(plan)
    return in_own_process(_check, blob, points, tolerance, max_placements, str(log))
