"""Every benchmark script answers ``--help`` (its arguments parse and its imports work) without
running; the few that take no arguments are listed here, so a new script is either listed or
answers ``--help``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
# scripts without command-line arguments (and stamp.py, a helper the others import)
NO_ARGUMENTS = {"bench_sal_periodic.py", "decay_facts.py", "g4_solid_limits.py", "stamp.py"}
SCRIPTS = sorted(p.name for p in BENCHMARKS.glob("*.py") if p.name not in NO_ARGUMENTS)


def test_the_scripts_without_arguments_are_the_listed_ones():
    for name in SCRIPTS:
        text = (BENCHMARKS / name).read_text()
        assert "argparse" in text or "click" in text, f"{name}: no --help; list it or add one"
    assert all((BENCHMARKS / name).exists() for name in NO_ARGUMENTS)


# ~0.4 s of CPU per script (12 s for all: the scripts import score4, numpy, h5py, some dask), so
# under `deep`, out of `make test`'s budget
@pytest.mark.deep
@pytest.mark.parametrize("name", SCRIPTS)
def test_benchmark_script_answers_help(name):
    out = subprocess.run(
        [sys.executable, str(BENCHMARKS / name), "--help"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=BENCHMARKS,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert "usage" in out.stdout.lower(), out.stdout[:500]
