"""Geantinos on chosen rays through a configured world: the run the geantino-path tests
compare with their analytic ray traces."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.source.vertex_file import write_vertex_file


def geantino_run(data: dict, primaries, start: np.ndarray, direction: np.ndarray, folder: Path):
    """Results of ``data``'s world with ``primaries`` (drawn from its source, one per ray)
    moved onto the rays ``start`` + s ``direction``: written as a vertex file in ``folder``
    and replayed, one event per ray."""
    primaries.position[:] = start
    primaries.direction[:] = direction
    vfile = write_vertex_file(folder / "v.h5", primaries, {}, 1)
    n = len(primaries.position)
    replay = parse_config({**data, "source": {"vertices": str(vfile)}, "run": {"events": n}})
    return read_results(run(replay, folder / "g.h5", progress=False, echo=lambda m: None))
