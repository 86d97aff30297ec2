"""Geantino paths through a run's world three ways (issue 24 item 5): as score4 builds it, as
Geant4's GDML reader reads its export, and as Geant4 reads that export after pyg4ometry read and
wrote it again. Each runs in a spawned process (:mod:`helpers.g4_gdml_world`)."""

from __future__ import annotations

import re
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


def three_paths(config: Path, exported: Path, rays: list, monkeypatch) -> tuple[list, list, list]:
    """The paths of ``rays`` ((origin, direction) pairs, world frame) through the world of
    ``config``, through its export ``exported`` and through pyg4ometry's copy of that export
    (read without meshing, which it cannot do for every rough solid)."""
    import pyg4ometry

    ours = run_in_spawned_process(_call, "trace_built", str(config), rays)
    back = run_in_spawned_process(_call, "trace_gdml", str(exported), rays)
    monkeypatch.setattr(pyg4ometry.config, "doMeshing", False)
    monkeypatch.chdir(exported.parent)  # pyg4ometry reads <file> includes from the working folder
    reg = pyg4ometry.gdml.Reader(str(exported)).getRegistry()
    again = exported.with_name(f"{exported.stem}_again.gdml")
    writer = pyg4ometry.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(again))
    relay = run_in_spawned_process(_call, "trace_gdml", str(again), rays)
    return ours, back, relay


def assert_same_paths(ours: list, *others: list, atol: float = 1e-9) -> None:
    """The same volumes crossed in the same order, at the same points to ``atol`` mm."""
    for other in others:
        assert len(other) == len(ours)
        for a, b in zip(ours, other, strict=True):
            names, again = [base_name(v) for v, _ in a], [base_name(v) for v, _ in b]
            diff = [(x, y) for x, y in zip(names, again, strict=False) if x != y][:3]
            assert names == again, (len(names), len(again), diff)
            np.testing.assert_allclose([p for _, p in a], [p for _, p in b], atol=atol, rtol=0)
