"""score4.inputs.limits: the limits of inputs, each checked against what it stands for.

Geant4's smallest solid and its NIST names in Geant4 itself (a subprocess), the memory estimates
against tracemalloc, the vertex and finiteness checks on hand-made arrays.
"""

from __future__ import annotations

import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs import limits
from score4.inputs.materials import shipped_nist_names
from score4.surface.spec import build_surface, parse_surface_spec

HERE = Path(__file__).parent


def _g4_box(size_mm: float) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(HERE / "helpers" / "g4_limits.py"), repr(size_mm)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_geant4_builds_the_smallest_allowed_box_and_aborts_just_below_its_own_limit():
    """MIN_LENGTH is above Geant4's real limit (4 pm boxes: 2 x kCarTolerance half-lengths), and
    that limit is real: 0.9 x of it aborts Geant4 with 'Dimensions too small'."""
    ok = _g4_box(limits.MIN_LENGTH)
    assert ok.returncode == 0, ok.stderr[-2000:]
    assert "BUILT True" in ok.stdout
    assert "G4Exception" not in ok.stdout + ok.stderr
    assert limits.MIN_LENGTH >= 2 * limits.GEANT4_SMALLEST_BOX
    # the process reading configurations checks materials with the shipped list: Geant4's own
    nist = next(line for line in ok.stdout.splitlines() if line.startswith("NIST "))
    assert tuple(nist.removeprefix("NIST ").split("|")) == shipped_nist_names()
    refused = _g4_box(0.9 * limits.GEANT4_SMALLEST_BOX)
    assert refused.returncode != 0
    assert "Dimensions too small" in refused.stdout + refused.stderr


def _peak(spec: dict) -> tuple[int, int]:
    """(tracemalloc peak of building the surface, its mesh and closed body; cells), built a
    second time (the imports and FFT plans of a first build are not what the estimate is for)."""
    build_surface(parse_surface_spec(spec)).body(1e-3)
    tracemalloc.start()
    surface = build_surface(parse_surface_spec(spec))
    surface.body(1e-3)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak, spec["nx"] * spec["ny"]


@pytest.mark.parametrize(
    ("spec", "estimate"),
    [
        (
            {"kind": "spikes", "nx": 60, "ny": 50, "width": "5 um", "height": "2 um"},
            lambda n: limits.spike_grid_bytes(n, 1),
        ),
        (
            {
                "kind": "spikes",
                "nx": 40,
                "ny": 30,
                "width": "5 um",
                "height": "2 um",
                "shape": "bump",
                "n_layers": 4,
            },
            lambda n: limits.spike_grid_bytes(n, 4),
        ),
        (
            {
                "kind": "random",
                "nx": 128,
                "ny": 96,
                "pitch": "1 um",
                "sq": "1 um",
                "corr_length": "5 um",
                "skewness": 0.3,
                "kurtosis": 3.5,
            },
            limits.heightmap_bytes,
        ),
    ],
)
def test_memory_estimates_cover_what_building_takes(spec, estimate):
    """Each estimate is at least the measured peak and at most 4x it (tolerance: the estimates
    round measured constants up; small grids carry fixed overheads)."""
    peak, n = _peak(spec)
    assert peak <= estimate(n) <= 4 * peak, (peak, estimate(n))


def test_a_surface_beyond_the_memory_is_refused_before_it_is_built(monkeypatch):
    monkeypatch.setattr(limits, "memory_limit", lambda: 10 * 2**20)
    spec = {"kind": "spikes", "nx": 200, "ny": 200, "width": "5 um", "height": "2 um"}
    with pytest.raises(ConfigError) as err:
        parse_surface_spec(spec, origin="s.yaml")
    assert str(err.value).startswith(
        "s.yaml: nx, ny: a grid of 200 x 200 spikes of 1 layer(s) needs about 49.6 MiB of memory, "
        "more than this machine's 10 MiB"
    )


def test_vertices_outside_the_world_or_not_finite_are_refused_with_their_event():
    half = np.array([5.0, 5.0, 10.0])
    limits.check_vertices(np.array([[4.9, -4.9, 9.9]]), half, "source")
    with pytest.raises(ConfigError, match=r"^source: the vertex of event 8 at \(0, 0, -10\) mm"):
        limits.check_vertices(
            np.array([[0.0, 0, 1], [0, 0, -10]]), half, "source", np.array([7, 8])
        )
    with pytest.raises(ConfigError, match=r"vertex of row 0 is \(nan, 0, 0\) mm, not a finite"):
        limits.check_vertices(np.array([[np.nan, 0, 0]]), half, "v.h5")


def test_finite_and_length_checks_name_the_entry():
    with pytest.raises(ConfigError, match=r"^col: entry \(1, 0\) is inf"):
        limits.check_finite(np.array([[1.0, 2.0], [np.inf, 0.0]]), "col")
    assert limits.check_length(2e-5, "pitch") == 2e-5
    with pytest.raises(ConfigError, match="shorter than 10 pm"):
        limits.check_length(1e-9, "pitch")
    with pytest.raises(ConfigError, match="longer than 100 m"):
        limits.check_length(1e6, "pitch")


def test_event_counts_have_a_stated_ceiling():
    assert limits.too_many_events(10**12) is None
    assert "more than score4's limit of 1e12" in limits.too_many_events(10**12 + 1)
