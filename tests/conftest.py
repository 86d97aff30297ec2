"""Shared fixtures. Geant4 runs happen in spawned worker processes, so each test run is isolated."""

from __future__ import annotations

import copy
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config

ROOT = Path(__file__).resolve().parents[1]

BASE_CONFIG = {
    "physics": "lite",
    "targets": [
        {
            "name": "crystal",
            "material": "G4_Si",
            "size": ["1 cm", "1 cm", "1 cm"],
            "position": ["0 cm", "0 cm", "-0.5 cm"],
        }
    ],
    "source": {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "crystal", "face": "+z"},
    },
    "run": {"events": 100, "seed": 7},
}


# Two silicon detectors facing each other across a 0.05 mm gap (templates, model tests).
DETECTOR_PAIR = [
    {
        "name": "top",
        "material": "G4_Si",
        "size": ["2 mm", "2 mm", "0.5 mm"],
        "position": ["0 mm", "0 mm", "0.3 mm"],
    },
    {
        "name": "bottom",
        "material": "G4_Si",
        "size": ["2 mm", "2 mm", "0.5 mm"],
        "position": ["0 mm", "0 mm", "-0.25 mm"],
    },
]


def config_dict(**sections) -> dict:
    """BASE_CONFIG with top-level sections updated (shallow per section)."""
    data = copy.deepcopy(BASE_CONFIG)
    for key, value in sections.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    return data


def tmpfs_mount_command(folder: Path) -> list[str] | None:
    """The unshare command that lets this user mount a tmpfs on ``folder`` privately, or None.

    Full-disk tests mount a small tmpfs in a private mount namespace: a real full disk.
    """
    if not shutil.which("unshare"):
        return None
    for cmd in (["unshare", "-m"], ["unshare", "-rm"]):
        probe = subprocess.run(
            [*cmd, "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {folder}"],
            check=False,
            capture_output=True,
        )
        if probe.returncode == 0:
            return cmd
    return None


@pytest.fixture
def make_config():
    return lambda **sections: parse_config(config_dict(**sections))


def pyramid_triangles(nx: int, ny: int, pitch: float = 1.0, heights=1.0) -> np.ndarray:
    """(4 nx ny, 3, 3) upward-facing triangles of square pyramids on an nx x ny grid.

    ``heights`` is a scalar or an (nx, ny) array; pyramid (i, j) has its base corner at
    (i * pitch, j * pitch).
    """
    heights = np.broadcast_to(np.asarray(heights, dtype=float), (nx, ny))
    tris = []
    for i in range(nx):
        for j in range(ny):
            x0, y0 = i * pitch, j * pitch
            a, b = [x0, y0, 0], [x0 + pitch, y0, 0]
            c, d = [x0 + pitch, y0 + pitch, 0], [x0, y0 + pitch, 0]
            top = [x0 + pitch / 2, y0 + pitch / 2, heights[i, j]]
            tris += [[a, b, top], [b, c, top], [c, d, top], [d, a, top]]
    return np.array(tris)


def replay_vertices(tmp_path: Path, data: dict, vfile: Path, n: int, name: str):
    """Run config dict ``data`` on the ``n`` events of vertex file ``vfile`` with track lengths
    scored (seed 5); the results read back from ``tmp_path / name.h5``."""
    from score4.runner.engine import run
    from score4.runner.output import read_results

    replayed = parse_config(
        {
            **data,
            "source": {"vertices": str(vfile)},
            "output": {"track_length": True},
            "run": {"events": n, "seed": 5},
        }
    )
    return read_results(run(replayed, tmp_path / f"{name}.h5", progress=False, echo=lambda m: None))


# A spike grid with a height spread (bumps of 3 layers) and the small target the solid tests
# (test_blocks, test_frustums, test_block_body) put it on.
SPREAD = {
    "kind": "spikes",
    "nx": 5,
    "ny": 4,
    "width": "10 um",
    "height": "8 um",
    "height_sigma": "2 um",
    "shape": "bump",
    "n_layers": 3,
    "seed": 4,
}
TARGET = {
    "name": "crystal",
    "material": "G4_Si",
    "size": ["0.2 mm", "0.2 mm", "0.1 mm"],
    "position": ["0 mm", "0 mm", "-0.05 mm"],
}


def crystal_track_lengths(tmp_path: Path, configs: dict, primaries) -> dict:
    """Replay the same ``primaries`` through each config dict of ``configs`` (name -> data);
    the track length in the crystal group per event, by name."""
    from score4.source.vertex_file import write_vertex_file

    vfile = write_vertex_file(tmp_path / "rays.h5", primaries, {}, 1)
    n = primaries.n_events
    return {
        name: replay_vertices(tmp_path, data, vfile, n, name).scores["track_length"]["crystal"]
        for name, data in configs.items()
    }


def straight_down_paths(config, primaries) -> tuple[np.ndarray, np.ndarray]:
    """(mask of the rays straight down, their exact path in the crystal group): mesh height at
    the ray + slab + the target's depth (first layer of ``config``)."""
    from score4.world.resolve import build_scene

    layer = build_scene(config).layers[0]
    down = (primaries.direction == [0.0, 0.0, -1.0]).all(axis=1)
    i, j = layer.patch_map.cell_of(primaries.position[down, :2])
    c = layer.cell_centres()[j, i]
    p = primaries.position[down]
    exact = layer.variants[0].height_at(p[:, 0] - c[:, 0], p[:, 1] - c[:, 1])
    return down, exact + layer.base_thickness + config.targets[0].size[2]


def pytest_configure(config) -> None:
    """``--dist loadgroup`` needs pytest < 9.2 with pytest-xdist 3.8: pytest 9.2 ignores the
    ``@group`` suffix xdist puts on test ids, so xdist_group marks would do nothing and tests that
    must not run side by side (several worker processes each) would. Stop with the reason.
    On xdist worker gw0, start the collection progress line (see pytest_collectreport)."""
    import sys
    from importlib.metadata import version

    worker = getattr(config, "workerinput", {}).get("workerid")
    if worker == "gw0" and not config.option.collectonly:
        _COLLECTION_ECHO[0] = True
        sys.stderr.write("collecting the test files on each xdist worker: ")
        sys.stderr.flush()
    if getattr(config.option, "dist", None) != "loadgroup" or hasattr(config, "workerinput"):
        return
    pytest_version = tuple(int(x) for x in pytest.__version__.split(".")[:2])
    xdist_version = tuple(int(x) for x in version("pytest-xdist").split(".")[:2])
    if pytest_version >= (9, 2) and xdist_version <= (3, 8):
        raise pytest.UsageError(
            f"pytest {pytest.__version__} ignores pytest-xdist {version('pytest-xdist')}'s test "
            "groups (xdist_group marks): install pytest<9.2 (pip install -e '.[test]')"
        )


#: xdist worker gw0 reports its collection on stderr (xdist shows nothing until every worker has
#: collected: ~10 s of CPU per worker, minutes on a loaded machine); set in pytest_configure.
_COLLECTION_ECHO: list[bool] = [False]


def pytest_collectreport(report) -> None:
    """A dot on stderr per test file gw0 has collected (only under xdist; its own progress
    line starts once all workers have collected)."""
    import sys

    if _COLLECTION_ECHO[0] and report.nodeid.endswith(".py"):
        sys.stderr.write(".")
        sys.stderr.flush()


def pytest_collection_finish(session) -> None:
    import sys

    if _COLLECTION_ECHO[0]:
        sys.stderr.write(f" {len(session.items)} tests collected on each worker\n")
        sys.stderr.flush()


def _cpu_seconds() -> float:
    """User + system CPU of this process and of the children it has waited for (spawned
    Geant4 processes, run workers, CLI subprocesses)."""
    import resource

    own, children = (
        resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """With ``SCORE4_TEST_CPU=<file>``, append one line per test to that file: the CPU seconds
    of its set-up, call and tear-down (a shared fixture counts with the first test that uses
    it), a tab, its id, then (tab-separated) the xdist worker and the wall-clock start and end
    (Unix seconds) to read the schedule. Measures only (no test depends on it): where the
    suite's CPU goes, e.g.
    ``SCORE4_TEST_CPU=/tmp/cpu.tsv make test; sort -rn /tmp/cpu.tsv | head -20``."""
    import os
    import time

    path = os.environ.get("SCORE4_TEST_CPU")
    before = _cpu_seconds() if path else 0.0
    start = time.time()
    yield
    if path:
        worker = os.environ.get("PYTEST_XDIST_WORKER", "-")
        with open(path, "a") as out:  # one short append per line: xdist workers share the file
            out.write(
                f"{_cpu_seconds() - before:.2f}\t{item.nodeid}\t{worker}"
                f"\t{start:.2f}\t{time.time():.2f}\n"
            )
