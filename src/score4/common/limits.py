"""What Geant4, numpy and this machine can hold, checked before anything is built.

Every limit of score4's inputs lives here with the reason for its value: the configuration
schema (:mod:`score4.common.schema`), the file readers and the builders all check against these, so
a value that would abort Geant4, exhaust the memory or make no physical sense is refused as one
line naming the parameter, the value and the rule, before any work starts.

Sizes
    :data:`MIN_LENGTH` (10 pm) is the smallest positive length anywhere. Geant4 refuses boxes and
    trapezoids thinner than 4 pm (a half-length below twice its surface tolerance kCarTolerance
    = 1e-9 mm: ``G4Box ... Dimensions too small``, a fatal G4Exception that aborts the process)
    and triangular facets narrower than ~1.4 pm (``Facet is too small or too narrow``), measured
    with geant4_pybind 0.1.3 / Geant4 11.4 by ``benchmarks/g4_solid_limits.py``; 10 pm keeps a
    2.5x margin, and no size or depth below an atom's (~100 pm) means anything here.
    :data:`MAX_LENGTH` (100 m) is the largest; the world may reach :data:`MAX_WORLD_EXTENT` from
    the origin.
Memory
    :func:`check_memory` refuses a surface, patch map, tile library, vertex batch or result
    that would need more than this machine's memory, from the ``*_bytes`` estimates below
    (measured with tracemalloc, see each constant).
Vertices
    :func:`check_vertices` refuses vertices outside the world or not finite: Geant4 crashes on
    a primary outside its world (a segmentation fault in the worker) or loses it silently.
"""

from __future__ import annotations

import math
import os

import numpy as np

from score4.errors import ConfigError

#: Smallest positive length, mm (10 pm); see the module docstring.
MIN_LENGTH = 1e-8
#: What Geant4 11.4 itself accepts (full size, mm): G4Box and G4Trd 4 pm, G4TriangularFacet
#: ~1.4 pm (benchmarks/g4_solid_limits.py); tests/test_limits.py checks these in Geant4.
GEANT4_SMALLEST_BOX = 4e-9
#: Largest length, mm: 100 m. The largest rare-event detectors and their shields are ~10 m; a
#: larger value is a unit slip ("10 km" for "10 mm").
MAX_LENGTH = 100e3
#: Farthest point of the world from the origin, mm (1 km): double precision still resolves
#: Geant4's tolerance (1e-9 mm) there a hundred times over.
MAX_WORLD_EXTENT = 1e6
#: Largest energy, MeV: 100 TeV, the top of Geant4's electromagnetic physics tables
#: (G4EmParameters::MaxKinEnergy); nothing above it is tracked as it should be.
MAX_ENERGY = 100e6
#: Densities, g/cm3. Osmium, the densest element, is 22.59 g/cm3: above 30 is a unit slip
#: (kg/m3 read as g/cm3). Below 1e-12 g/cm3 (air at ~1e-6 mbar) a material is vacuum: use
#: G4_Galactic.
MIN_DENSITY, MAX_DENSITY = 1e-12, 30.0
#: Most events of one run: score4 keeps every event in one results file (~150 bytes an event,
#: see :func:`results_bytes`), so 10^12 events would be ~150 TB. (Whether this machine can merge
#: a run's results is checked at its start: :func:`results_bytes`.)
MAX_EVENTS = 10**12
#: Longest name (a material, a volume, a particle, a key of a mapping) and longest file name in
#: a description: error messages quote names, and none needs more.
MAX_NAME, MAX_PATH = 256, 4096
#: YAML documents: deepest nesting and most values after aliases are expanded. A run
#: description is ~6 levels deep and holds a few hundred values; the limits stop "billion
#: laughs" alias bombs and the recursion of 5000-deep nesting.
MAX_YAML_DEPTH = 64
MAX_YAML_VALUES = 200_000

# Memory per element, bytes (tracemalloc peaks of 60 x 50 to 300 x 300 spikes and 40 x 30 to
# 1024 x 1024 maps, with the closed body the geometry builds): pyramids 684-718 a spike, bumps
# of 4 layers 1220-1243 a spike layer; random maps 364-402 a point; the spike picture (16 x 16
# samples a spike) 20.7 kB. tests/test_limits.py checks them.
SPIKE_LAYER_BYTES = 1300
MAP_POINT_BYTES = 450
SPIKE_PICTURE_BYTES = 21_000
#: A patch-map cell is an int32, with a shuffled copy and the permutation while it is drawn.
CELL_BYTES = 24
#: Most bins on one axis of a histogram (spectra, templates, CSV and ROOT exports): 10 eV bins
#: over 10 MeV, a hundred times finer than the best detectors resolve (germanium, ~1 keV FWHM
#: at 1 MeV); more only costs memory (a 2D coincidence template holds bins squared).
MAX_BINS = 10**6
#: A histogram bin in memory: counts, rate, error and expected counts (float64) and numpy's
#: temporaries while it is filled.
BIN_BYTES = 48
#: A Geant4 worker process of a run: peak resident memory of a lite-physics worker (a GDML
#: world of two boxes, 3000 alphas), 150 MB by /proc VmRSS; full physics and large worlds need
#: more, so this is a lower bound for ``--jobs``.
WORKER_BYTES = 150 * 2**20
#: A primary particle in memory (event, energy, position, direction, depth, facet, patch, name).
PRIMARY_BYTES = 120


def too_many_events(n: int) -> str | None:
    """Why ``n`` events are more than a run can hold, or None."""
    if n <= MAX_EVENTS:
        return None
    return (
        f"{n:.3g} events are more than score4's limit of 1e12: the results file keeps every "
        "event (~150 bytes each: 150 TB for 1e12 events)"
    )


def _gib(nbytes: float) -> str:
    return f"{nbytes / 2**30:.3g} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.3g} MiB"


#: Environment variable that sets the memory score4 plans with, in bytes ("64e9"): for a
#: container whose limit is below the machine's memory, or a test of a run too large to merge.
MEMORY_ENV = "SCORE4_MEMORY_LIMIT"


def memory_limit() -> int:
    """Bytes of memory one process may plan to use: $SCORE4_MEMORY_LIMIT, else this machine's
    physical memory."""
    if os.environ.get(MEMORY_ENV):
        from .units import parse_count

        return parse_count(os.environ[MEMORY_ENV], MEMORY_ENV)
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # not POSIX: no check
        return 2**62


def check_memory(nbytes: float, what: str, label: str, hint: str = "") -> None:
    """Refuse ``what`` (named by ``label``) when it needs more than this machine's memory."""
    limit = memory_limit()
    if nbytes > limit:
        more = f"; {hint}" if hint else ""
        raise ConfigError(
            f"{label}: {what} needs about {_gib(nbytes)} of memory, more than this machine's "
            f"{_gib(limit)}{more}"
        )


def check_bins(
    bins: int, label: str, n_1d: int = 1, n_2d: int = 0, hint: str = "use fewer bins"
) -> None:
    """Refuse ``bins`` bins an axis above :data:`MAX_BINS`, or histograms (``n_1d`` of one axis,
    ``n_2d`` of two) that need more than this machine's memory."""
    if bins > MAX_BINS:
        raise ConfigError(
            f"{label}: {bins} bins are more than score4's limit of {MAX_BINS} an axis (10 eV "
            "bins over 10 MeV, finer than any detector resolves)"
        )
    what = f"{n_1d} histogram(s) of {bins} bins" + (
        f" and {n_2d} coincidence histogram(s) of {bins} x {bins} bins" if n_2d else ""
    )
    check_memory(BIN_BYTES * (n_1d * bins + n_2d * bins**2), what, label, hint)


def spike_grid_bytes(n_spikes: int, n_layers: int = 1) -> int:
    """Memory to build a spike grid's mesh and closed body."""
    return int(n_spikes) * max(1, int(n_layers)) * SPIKE_LAYER_BYTES


def heightmap_bytes(n_points: int) -> int:
    """Memory to build a height map with its mesh and closed body."""
    return int(n_points) * MAP_POINT_BYTES


def results_bytes(n_events: int, n_columns: int, primaries_per_event: float = 1.0) -> int:
    """Memory to merge a run's results: the file's image and the concatenated columns.

    ``n_columns`` per-event float64 columns (event id, primary energy, one per scored volume and
    quantity) plus the primaries, twice (the columns, then the HDF5 image of the file).
    """
    per_event = 8 * int(n_columns) + PRIMARY_BYTES * primaries_per_event
    return int(2 * n_events * per_event)


def check_length(value: float, label: str, positive: bool = True) -> float:
    """``value`` (mm) if it is a finite length within [MIN_LENGTH, MAX_LENGTH]; else ConfigError.

    For lengths read from files (pitches of text grids, depths of tables), which the schema
    does not see.
    """
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(f"{label}: must be a finite length, got {v}")
    if abs(v) > MAX_LENGTH:
        raise ConfigError(
            f"{label}: {v:g} mm is longer than 100 m, score4's limit for any length (a unit slip?)"
        )
    if positive and v < MIN_LENGTH:
        raise ConfigError(
            f"{label}: {v:g} mm is shorter than 10 pm, the smallest length Geant4 builds solids "
            "of (with a margin)"
        )
    return v


def check_finite(values: np.ndarray, label: str) -> np.ndarray:
    """``values`` if every entry is a finite number; else a ConfigError naming the first bad one."""
    a = np.asarray(values)
    if a.dtype.kind in "fc":
        bad = ~np.isfinite(a)
        if bad.any():
            where = tuple(int(i) for i in np.argwhere(bad)[0])
            at = where[0] if len(where) == 1 else where
            raise ConfigError(
                f"{label}: entry {at} is {a[where]}; every value must be a finite number"
            )
    return a


def _xyz(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in p) + ") mm"


def check_vertices(
    positions: np.ndarray, half: np.ndarray, label: str, events: np.ndarray | None = None
) -> None:
    """Refuse vertices that are not finite or lie outside the world box ``|x_i| < half_i``.

    ``events`` (one per row) names the event of the first bad vertex.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    if not len(p):
        return
    finite = np.isfinite(p).all(axis=1)
    outside = ~finite | (np.abs(np.where(finite[:, None], p, 0.0)) >= np.asarray(half)).any(axis=1)
    if not outside.any():
        return
    row = int(np.argmax(outside))
    which = f"event {int(events[row])}" if events is not None else f"row {row}"
    if not finite[row]:
        raise ConfigError(f"{label}: the vertex of {which} is {_xyz(p[row])}, not a finite point")
    raise ConfigError(
        f"{label}: the vertex of {which} at {_xyz(p[row])} lies outside the world (|x|, |y|, |z| < "
        f"{_xyz(np.asarray(half))}: the targets and world.margin); Geant4 cannot start a particle "
        "there"
    )
