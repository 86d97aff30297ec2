"""Geantinos on chosen rays through a configured world: the run the geantino-path tests
compare with their analytic ray traces."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.source.vertex_file import write_vertex_file


def geantino_config(
    gdml: Path,
    surfaces: dict,
    targets: list[dict],
    source: tuple[str, str | list[str]],
    /,
    **extra,
) -> dict:
    """The configuration of a geantino-path test: the GDML world ``gdml`` in lite physics, the
    ``surfaces`` and ``targets`` sections given, 1 MeV geantinos drawn on ``source`` (volume,
    face or faces), 10 events of seed 3, then the ``extra`` sections, which replace any of
    these (a test's own ``source`` section included)."""
    volume, face = source
    return {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": surfaces,
        "targets": targets,
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": volume, "face": face},
        },
        "run": {"events": 10, "seed": 3},
        **extra,
    }


def rough_targets(rough: dict[str, list[str]], surface: str = "p", into: bool = False) -> list:
    """``targets`` with a layer of ``surface`` on each face that ``rough`` names per volume
    (``into: true`` on each if ``into``)."""
    more = {"into": True} if into else {}
    return [
        {"volume": v, "rough": [{"face": f, "surface": surface, **more} for f in faces]}
        for v, faces in rough.items()
    ]


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


def assert_box_paths(
    data: dict,
    scene,
    start: np.ndarray,
    direction: np.ndarray,
    owners: list[str],
    traced,
    volume_of,
    folder: Path,
) -> int:
    """Geantinos along the rays ``start`` + s ``direction`` (world), ray k aimed at the volume
    ``owners[k]`` (unrotated): Geant4's track length in it equals ``traced(name, o, d)`` (the
    analytic path, ``o`` in the volume's frame) plus the path in the patch bodies of its layers
    (helpers.ray_trace.patches_path), 1e-9 mm; Geant4's volume of each scored volume less its
    layers equals ``volume_of(name)`` to 2e-4 (Geant4 estimates a boolean's volume from 10^6
    points). Returns how many rays crossed a patch."""
    import pytest

    from score4.source.build import make_source

    from helpers.ray_trace import patches_path

    config = parse_config(data)
    primaries = make_source(config, scene).primaries(np.random.default_rng(1), 0, len(start))
    res = geantino_run(data, primaries, start, direction, folder)
    crossed = 0
    for k, name in enumerate(owners):
        o = scene.target(name).to_local(start[k][None])[0]
        layers = scene.layers_of(name)  # a polyhedra's sides: a layer per plane
        in_patches = sum(patches_path(start[k], direction[k], layer) for layer in layers)
        crossed += in_patches > 0
        expected = traced(name, o, direction[k]) + in_patches
        got = np.asarray(res.scores["track_length"][name])[k]
        assert got == pytest.approx(expected, abs=1e-9, rel=0), (name, k)
    for vol in res.run["volumes"]:
        own = vol["volume_mm3"] - vol["layer_volume_mm3"]
        assert own == pytest.approx(volume_of(vol["name"]), rel=2e-4), vol["name"]
    return crossed
