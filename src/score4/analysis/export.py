"""Export results files to formats other tools read: histogram CSV, per-event CSV, ROOT.

All energies are in MeV. The energy-deposit histograms here and in :mod:`score4.analysis.plots`
share one definition (:func:`histogram_edges`, :func:`deposit_histogram`):

* bins are ``numpy.linspace(emin, emax, bins + 1)``; ``bins`` and ``emax`` default to the
  run's ``output.histogram`` settings, else 100 bins up to the largest primary energy;
* events with **no** deposit (exactly 0 MeV) are not counted in any bin, they are reported
  separately (they are usually particles that flew away);
* sums of step deposits can exceed the emitted energy by rounding (1e-15 MeV): values within
  a relative 1e-9 above ``emax`` count in the top bin; larger values are overflow.

The ROOT file (written with ``uproot``) holds a TTree ``events`` (branches ``event_id``,
``primary_energy``, ``edep_<volume>`` and, if scored, ``track_length_<volume>`` in mm), one
TH1D ``edep_<volume>`` per volume (this histogram, overflow in ROOT's overflow bin), and a
TObjString ``run`` with the run record (seed, physics mode, versions, configuration) as JSON.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from score4.common import limits
from score4.common.units import parse_quantity
from score4.errors import ConfigError
from score4.files import atomic_output, check_output_file
from score4.runner.output import QUANTITY_UNITS, Results

DEFAULT_BINS = 100
TOP_TOLERANCE = 1e-9  # relative: deposits this close above emax count in the top bin


@dataclass(frozen=True)
class DepositHistogram:
    """A histogram of the non-zero energy deposits of one volume.

    Attributes
    ----------
    edges : (bins + 1,) bin edges, MeV.
    counts : (bins,) events per bin (int64).
    n_zero : events with no deposit (not in any bin).
    n_underflow, n_overflow : non-zero deposits below ``edges[0]`` / above ``edges[-1]``.
    n_events : all events of the run.
    """

    edges: np.ndarray
    counts: np.ndarray
    n_zero: int
    n_underflow: int
    n_overflow: int
    n_events: int

    @property
    def widths_keV(self) -> np.ndarray:
        return np.diff(self.edges) * 1e3

    @property
    def counts_per_keV(self) -> np.ndarray:
        """Counts divided by the bin width in keV."""
        return self.counts / self.widths_keV


def energy_value(value: float | str | None, name: str) -> float | None:
    """Energy in MeV from a float (MeV) or a string with a unit (``"6 MeV"``); None stays None."""
    if value is None:
        return None
    if isinstance(value, str):
        v = parse_quantity(value, "energy", name)
        if abs(v) > limits.MAX_ENERGY:
            raise ConfigError(
                f"{name}: {value!r} is above 100 TeV, the top of Geant4's electromagnetic "
                "physics tables (a unit slip?)"
            )
        return v
    given: object = value  # checked at run time: callers may pass anything
    if (
        isinstance(given, bool)
        or not isinstance(given, (int, float, np.number))
        or not np.isfinite(given)
    ):
        raise ConfigError(
            f"{name}: expected an energy in MeV or a string such as '6 MeV', got {value!r}"
        )
    return float(value)


def check_bins(bins: object) -> None:
    """Raise ConfigError unless ``bins`` is None or a positive integer."""
    if bins is not None and (
        isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or bins < 1
    ):
        raise ConfigError(f"bins: must be a positive integer, got {bins!r}")
    if bins is not None:
        limits.check_bins(int(bins), "bins")


def _run_histogram_setting(results: Results) -> tuple[int | None, float | None]:
    """The run's own ``output.histogram`` bins and max (MeV), if its stored config has them."""
    config = results.run.get("config")
    hist = config.get("output", {}).get("histogram", {}) if isinstance(config, dict) else {}
    if not isinstance(hist, dict):
        return None, None
    stored = hist.get("bins")
    bins = stored if isinstance(stored, int) and stored > 0 else None
    emax = None
    raw = hist.get("max")
    if raw is not None:
        try:
            emax = energy_value(raw, "output.histogram.max")
        except ConfigError:
            emax = None
    return bins, emax


def histogram_edges(
    results: Results | Iterable[Results],
    bins: int | None = None,
    emin: float | str | None = None,
    emax: float | str | None = None,
) -> np.ndarray:
    """Common bin edges (MeV) for one or several runs.

    Defaults: ``bins`` from the first run's ``output.histogram.bins`` (else 100); ``emin`` 0;
    ``emax`` the largest of the runs' ``output.histogram.max`` or largest primary energy.
    """
    runs = [results] if isinstance(results, Results) else list(results)
    if not runs:
        raise ConfigError("results: no results given")
    check_bins(bins)
    lo = energy_value(emin, "emin")
    hi = energy_value(emax, "emax")
    settings = [_run_histogram_setting(r) for r in runs]
    bins = int(bins or settings[0][0] or DEFAULT_BINS)
    lo = 0.0 if lo is None else lo
    if hi is None:
        hi = (
            max(
                s[1] or float(r.primary_energy.max(initial=0.0))
                for s, r in zip(settings, runs, strict=True)
            )
            or 1.0
        )
    if lo < 0:
        raise ConfigError(f"emin: must be >= 0 MeV, got {lo!r} MeV")
    if not hi > lo:
        raise ConfigError(f"emax: must be larger than emin ({lo!r} MeV), got {hi!r} MeV")
    return np.linspace(lo, hi, bins + 1)


def _nonzero_folded(edep: np.ndarray, top: float) -> np.ndarray:
    """The non-zero deposits, with rounding excess just above ``top`` folded onto ``top``."""
    edep = np.asarray(edep, dtype=float)
    nonzero = edep[edep != 0]
    at_top = (nonzero > top) & (nonzero <= top * (1 + TOP_TOLERANCE))
    return np.where(at_top, top, nonzero)


def deposit_histogram(edep: np.ndarray, edges: np.ndarray) -> DepositHistogram:
    """Histogram the non-zero deposits ``edep`` (MeV) in ``edges`` (see the module notes)."""
    top = edges[-1]
    values = _nonzero_folded(edep, top)
    counts, _ = np.histogram(values, bins=edges)
    return DepositHistogram(
        edges=edges,
        counts=counts.astype(np.int64),
        n_zero=int(np.size(edep) - len(values)),
        n_underflow=int(np.count_nonzero(values < edges[0])),
        n_overflow=int(np.count_nonzero(values > top)),
        n_events=len(edep),
    )


def select_volumes(results: Results, volume: str | None) -> list[str]:
    """``[volume]`` if ``results`` has it (else an error naming the volumes); all for None."""
    names = list(results.edep)
    if volume is None:
        return names
    if volume not in names:
        raise ConfigError(
            f"volume: {volume!r} is not a volume of {results.path}; volumes are: {', '.join(names)}"
        )
    return [volume]


def _header(results: Results, title: str) -> list[str]:
    run = results.run
    return [
        f"# {title}",
        f"# file: {results.path}",
        f"# events: {results.n_events}",
        f"# physics mode: {run.get('physics_mode')}",
        f"# seed: {run.get('seed')}",
    ]


def _num(x) -> str:
    """Shortest text that reads back as exactly the same float."""
    return repr(float(x))


def export_csv(
    results: Results,
    path: str | Path,
    volume: str | None = None,
    bins: int | None = None,
    emax: float | str | None = None,
    emin: float | str | None = None,
) -> list[DepositHistogram]:
    """Write the energy-deposit histogram(s) as CSV, one block of rows per volume.

    Columns: ``volume, bin_low_MeV, bin_high_MeV, counts, counts_per_keV``. Comment lines
    (``#``) before the header give the file, events, physics mode, seed and, per volume, the
    events without deposit and under/overflow (none of them are in ``counts``). Read it with
    ``pandas.read_csv(path, comment="#")``, or with numpy from the lines that do not start
    with ``#``: ``numpy.genfromtxt(lines, delimiter=",", names=True, dtype=None)``.

    Parameters
    ----------
    results : a loaded results file (:func:`score4.runner.output.read_results`).
    path : CSV file to write (atomically; an existing file is replaced).
    volume : one volume, or None for all.
    bins, emax, emin : binning, see :func:`histogram_edges` (energies in MeV or with a unit).

    Returns
    -------
    The histograms written, in volume order.
    """
    path = check_output_file(path, True, "output")  # the commands check --overwrite
    names = select_volumes(results, volume)
    edges = histogram_edges(results, bins=bins, emin=emin, emax=emax)
    hists = [deposit_histogram(results.edep[name], edges) for name in names]
    lines = _header(results, "score4 energy-deposit histogram (events with a non-zero deposit)")
    for name, h in zip(names, hists, strict=True):
        lines.append(
            f"# volume {name}: {h.n_zero} events without deposit, {h.n_underflow} below "
            f"{_num(edges[0])} MeV, {h.n_overflow} above {_num(edges[-1])} MeV (not counted)"
        )
    lines.append("volume,bin_low_MeV,bin_high_MeV,counts,counts_per_keV")
    for name, h in zip(names, hists, strict=True):
        per_keV = h.counts_per_keV
        for k in range(len(h.counts)):
            lines.append(
                f"{name},{_num(edges[k])},{_num(edges[k + 1])},"
                f"{int(h.counts[k])},{_num(per_keV[k])}"
            )
    with atomic_output(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return hists


def _event_columns(results: Results) -> dict[str, np.ndarray]:
    columns: dict[str, np.ndarray] = {
        "event_id": results.event_id,
        "primary_energy_MeV": results.primary_energy,
    }
    for quantity, per_volume in results.scores.items():
        unit = QUANTITY_UNITS.get(quantity, "")
        for name, values in per_volume.items():
            columns[f"{quantity}_{name}_{unit}" if unit else f"{quantity}_{name}"] = values
    return columns


def export_events_csv(results: Results, path: str | Path) -> list[str]:
    """Write one CSV row per event: ``event_id, primary_energy_MeV, edep_<volume>_MeV, ...``.

    Track lengths (``track_length_<volume>_mm``) follow when the run scored them. Floats are
    written as the shortest text that reads back exactly. Comment lines (``#``) come first,
    as in :func:`export_csv`. Returns the column names.
    """
    path = check_output_file(path, True, "output")  # the commands check --overwrite
    columns = _event_columns(results)
    lists = [np.asarray(c).tolist() for c in columns.values()]
    lines = _header(results, "score4 events: total primary energy and scores per volume")
    lines.append(",".join(columns))
    formats = [
        str if np.issubdtype(np.asarray(c).dtype, np.integer) else repr for c in columns.values()
    ]
    for row in zip(*lists, strict=True):
        lines.append(",".join(f(v) for f, v in zip(formats, row, strict=True)))
    with atomic_output(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return list(columns)


def _th1d(name: str, title: str, edep: np.ndarray, edges: np.ndarray):
    from uproot.writing.identify import to_TAxis, to_TH1x

    h = deposit_histogram(edep, edges)
    values = _nonzero_folded(edep, edges[-1])
    inside = values[
        (values >= edges[0]) & (values <= edges[-1])
    ]  # ROOT's statistics skip under/overflow
    data = np.concatenate([[h.n_underflow], h.counts, [h.n_overflow]]).astype(np.float64)
    axis = to_TAxis(
        "xaxis", "energy deposit [MeV]", len(h.counts), float(edges[0]), float(edges[-1])
    )
    return to_TH1x(
        name,
        title,
        data,
        fEntries=float(data.sum()),
        fTsumw=float(len(inside)),
        fTsumw2=float(len(inside)),
        fTsumwx=float(inside.sum()),
        fTsumwx2=float((inside**2).sum()),
        fSumw2=data.copy(),
        fXaxis=axis,
    )


def export_root(
    results: Results,
    path: str | Path,
    bins: int | None = None,
    emax: float | str | None = None,
    emin: float | str | None = None,
) -> Path:
    """Write a ROOT file (uproot): TTree ``events``, TH1D ``edep_<volume>``, TObjString ``run``.

    Branches (one entry per event): ``event_id`` (int64), ``primary_energy`` (MeV),
    ``edep_<volume>`` (MeV), ``track_length_<volume>`` (mm, if scored). The histograms count
    the events with a non-zero deposit (see the module notes); those above ``emax`` are in the
    overflow bin. ``run`` holds the run record as JSON (the stored configuration keeps its units).
    """
    import uproot

    path = check_output_file(path, True, "output")  # the commands check --overwrite
    edges = histogram_edges(results, bins=bins, emin=emin, emax=emax)
    branches: dict[str, np.ndarray] = {
        "event_id": np.asarray(results.event_id, dtype=np.int64),
        "primary_energy": np.asarray(results.primary_energy, dtype=np.float64),
    }
    for quantity, per_volume in results.scores.items():
        for name, values in per_volume.items():
            branches[f"{quantity}_{name}"] = np.asarray(values, dtype=np.float64)
    run_json = json.dumps(results.run, default=str, sort_keys=True)
    with atomic_output(path) as tmp, uproot.recreate(tmp) as f:
        tree = f.mktree(
            "events",
            {k: v.dtype for k, v in branches.items()},
            title=f"score4 events of {results.path.name} (energies MeV, lengths mm)",
        )
        if results.n_events:
            tree.extend(branches)
        for name, values in results.edep.items():
            f[f"edep_{name}"] = _th1d(
                f"edep_{name}", f"energy deposit in {name}, events with edep > 0", values, edges
            )
        f["run"] = run_json
    return path
