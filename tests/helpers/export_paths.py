"""Geantino paths through a run's world three ways (issue 24 item 5): as score4 builds it, as
Geant4's GDML reader reads its export, and as Geant4 reads that export after pyg4ometry read and
wrote it again. Each runs in a spawned process (:mod:`helpers.g4_gdml_world`)."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from helpers.spawn import run_in_spawned_process


def _call(name, *args):
    import sys

    sys.path.insert(0, str(Path(__file__).parents[1]))
    from helpers import g4_gdml_world

    return getattr(g4_gdml_world, name)(*args)


def base_name(name: str | None) -> str | None:
    """A physical volume name without what differs between the three worlds and means nothing:
    pyg4ometry's ``0x...`` suffixes and the export's numbering of repeated placements of score4's
    additions (``name``, ``name_1``, ...)."""
    if not name:
        return name
    name = re.sub(r"0x[0-9a-f]+$", "", name)
    return re.sub(r"_\d+$", "", name) if "_rough" in name else name


def built_and_exported(config: Path, exported: Path, rays: list, points: list | None = None):
    """The paths of ``rays`` ((origin, direction) pairs, world frame) through the world score4
    builds for ``config`` and through its export ``exported`` as Geant4's GDML reader reads it.
    With ``points``, the second is (paths, names of the physical volumes at ``points``)."""
    ours = run_in_spawned_process(_call, "trace_built", str(config), rays)
    extra = () if points is None else (points,)
    back = run_in_spawned_process(_call, "trace_gdml", str(exported), rays, *extra)
    return ours, back


def pyg4ometry_registry(exported: Path, monkeypatch):
    """``exported`` as pyg4ometry reads it (without meshing, which it cannot do for every rough
    solid; <file> includes are read from the file's folder)."""
    import pyg4ometry

    monkeypatch.setattr(pyg4ometry.config, "doMeshing", False)
    monkeypatch.chdir(exported.parent)
    return pyg4ometry.gdml.Reader(str(exported)).getRegistry()


def three_paths(config: Path, exported: Path, rays: list, monkeypatch) -> tuple[list, list, list]:
    """The paths of ``rays`` through the world of ``config``, through its export ``exported``
    and through pyg4ometry's copy of that export (:func:`pyg4ometry_registry` written again)."""
    import pyg4ometry

    ours, back = built_and_exported(config, exported, rays)
    reg = pyg4ometry_registry(exported, monkeypatch)
    again = exported.with_name(f"{exported.stem}_again.gdml")
    writer = pyg4ometry.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(again))
    relay = run_in_spawned_process(_call, "trace_gdml", str(again), rays)
    return ours, back, relay


def assert_same_paths(
    ours: list, *others: list, atol: float = 1e-9, names: Callable = base_name
) -> None:
    """The same volumes crossed in the same order (compared as ``names`` gives them), at the
    same points to ``atol`` mm."""
    for other in others:
        assert len(other) == len(ours)
        for a, b in zip(ours, other, strict=True):
            mine, again = [names(v) for v, _ in a], [names(v) for v, _ in b]
            diff = [(x, y) for x, y in zip(mine, again, strict=False) if x != y][:3]
            assert mine == again, (len(mine), len(again), diff)
            np.testing.assert_allclose([p for _, p in a], [p for _, p in b], atol=atol, rtol=0)
