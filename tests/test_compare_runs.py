"""tools/compare_runs.py: two results files compared event by event (files made without Geant4)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from score4.runner.output import merge_chunks, write_chunk
from score4.source.primaries import Primaries

from conftest import ROOT

TOOL = ROOT / "tools" / "compare_runs.py"


def results(folder: Path, name: str, edep: np.ndarray, **record) -> Path:
    """A results file of 10 events with deposits ``edep`` and run record ``record``."""
    folder.mkdir(exist_ok=True)
    p = Primaries(np.arange(10), ["alpha"] * 10, [5.3] * 10, np.zeros((10, 3)), [[0, 0, -1.0]] * 10)
    chunk = folder / f"{name}.chunk.h5"
    write_chunk(chunk, 0, ["crystal"], {"edep": edep.reshape(10, 1)}, p, "fp")
    out = folder / f"{name}.h5"
    merge_chunks([chunk], out, {"seed": 1, "host": "a", "wall_time_s": 1.0, **record})
    return out


def compare(a: Path, b: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(TOOL), str(a), str(b)], capture_output=True, text=True, check=False
    )


def test_same_events_with_other_times_and_hosts_are_the_same(tmp_path: Path):
    edep = np.linspace(0, 5, 10)
    a = results(tmp_path, "a", edep)
    b = results(tmp_path, "b", edep.copy(), host="b", wall_time_s=2.5)
    done = compare(a, b)
    assert done.returncode == 0, done.stdout
    assert done.stdout.startswith("SAME")
    assert len(done.stdout.strip().splitlines()) == 1


def test_a_different_deposit_or_seed_fails(tmp_path: Path):
    edep = np.linspace(0, 5, 10)
    a = results(tmp_path, "a", edep)
    other = edep.copy()
    other[3] = np.nextafter(other[3], 10)  # one event, by one ulp
    done = compare(a, results(tmp_path, "b", other))
    assert done.returncode == 1
    assert "/events/edep/crystal: 1 row(s) differ" in done.stdout
    done = compare(a, results(tmp_path, "c", edep, seed=2))
    assert done.returncode == 1
    assert "/run attribute seed" in done.stdout
    done = compare(a, results(tmp_path, "d", edep, extra=1))
    assert done.returncode == 1
    assert "extra: only in B" in done.stdout
    assert compare(a, tmp_path / "missing.h5").returncode == 2
