"""Pictures of results: energy-deposit spectra and vertex-depth histograms.

Figures are drawn on a bare :class:`matplotlib.figure.Figure` rendered by the Agg canvas, so
nothing needs a display and pyplot's global state (and the user's backend) is left alone. The
output format follows the file suffix (``.png``, ``.pdf``, ``.svg``, ...); files are written
atomically. Every plotting function returns the arrays it drew, so they can be checked.

Height maps of surfaces are drawn by :mod:`score4.surface.plot`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from matplotlib.figure import Figure

from score4.common.units import LENGTH
from score4.errors import ConfigError, Score4Error
from score4.files import atomic_output, check_output_file
from score4.runner.output import FORMAT as RESULTS_FORMAT
from score4.runner.output import Results, read_results

from .export import (
    DepositHistogram,
    check_bins,
    deposit_histogram,
    histogram_edges,
    select_volumes,
)

SURFACE_FORMAT = "score4-surface"
VERTEX_FORMAT = "score4-vertices"
VERTEX_DEPTH_DATASET = "vertices/depth"


@dataclass(frozen=True)
class Spectrum:
    """One drawn spectrum: ``y`` is counts per keV (per event if ``per_event``) on ``hist.edges``
    (MeV).

    ``legend`` is the full legend entry: ``label`` plus the events without deposit (not drawn),
    when there are any.
    """

    label: str
    legend: str
    file: Path
    volume: str
    hist: DepositHistogram
    y: np.ndarray
    per_event: bool


@dataclass(frozen=True)
class DepthHistogram:
    """One drawn depth histogram: ``counts`` per bin, ``per_nm`` per nm of depth, edges in nm."""

    label: str
    edges_nm: np.ndarray
    counts: np.ndarray
    per_nm: np.ndarray


# --- files -----------------------------------------------------------------------------------


def file_kind(path: str | Path) -> str:
    """``"results"``, ``"surface"`` or ``"vertices"`` for a score4 HDF5 file; a clear error
    otherwise.

    Results and surface files are told by their ``format`` attribute; a vertex file by a
    dataset ``vertices/depth`` (see :func:`read_vertex_depths`).
    """
    path = Path(path)
    if not path.is_file():
        raise Score4Error(
            f"file {str(path)!r} does not exist"
            if not path.exists()
            else f"{str(path)!r} is not a file"
        )
    try:
        f = h5py.File(path, "r")
    except OSError:
        raise Score4Error(
            f"{path} is not an HDF5 file (expected a score4 results, vertex or surface file)"
        ) from None
    with f:
        fmt = f.attrs.get("format")
        fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
        if fmt == RESULTS_FORMAT:
            return "results"
        if fmt == SURFACE_FORMAT:
            return "surface"
        if isinstance(f.get(VERTEX_DEPTH_DATASET), h5py.Dataset):
            return "vertices"
        if fmt == VERTEX_FORMAT:
            raise Score4Error(
                f"{path}: vertex file without depths (no dataset {VERTEX_DEPTH_DATASET!r}): "
                "nothing to plot"
            )
    shown = f" (format attribute {fmt!r})" if fmt is not None else " (no format attribute)"
    raise Score4Error(f"{path} is not a score4 results, vertex or surface file{shown}")


def read_vertex_depths(path: str | Path) -> np.ndarray:
    """One depth (mm) per event of a vertex file (``score4 vertices``, table ``/vertices``).

    The table has one row per primary (two per Po-210 decay, which share the vertex), so the
    depth of the first row of each event is taken. Honours a ``units`` attribute (mm when absent).
    """
    path = Path(path)
    if file_kind(path) != "vertices":
        raise Score4Error(f"{path} is not a vertex file (no dataset {VERTEX_DEPTH_DATASET!r})")
    with h5py.File(path, "r") as f:
        d = f[VERTEX_DEPTH_DATASET]
        unit = d.attrs.get("units", "mm")
        unit = unit.decode() if isinstance(unit, bytes) else str(unit)
        if unit not in LENGTH:
            raise Score4Error(
                f"{path}: {VERTEX_DEPTH_DATASET} has units {unit!r}; expected one of: "
                f"{', '.join(LENGTH)}"
            )
        depth = np.asarray(d[()], dtype=float).reshape(-1) * LENGTH[unit]
        if "vertices/event" in f:
            event = np.asarray(f["vertices/event"][()]).reshape(-1)
            first = np.ones(len(event), dtype=bool)
            first[1:] = event[1:] != event[:-1]
            depth = depth[first]
        return depth


# --- labels ----------------------------------------------------------------------------------


def _dict(value: object) -> dict:
    """``value`` if it is a dict, else an empty one (stored configs may come from anywhere)."""
    return value if isinstance(value, dict) else {}


def _text(value) -> str | None:
    return (
        str(value) if isinstance(value, (str, int, float)) and not isinstance(value, bool) else None
    )


def _emitter_text(source: dict) -> str | None:
    particle, energy = _text(source.get("particle")), _text(source.get("energy"))
    if particle:
        spectrum = source.get("spectrum")
        if not energy and isinstance(spectrum, dict) and _text(spectrum.get("file")):
            energy = f"spectrum {Path(str(spectrum['file'])).name}"
        return " ".join(v for v in (particle, energy) if v)
    for key in ("decay", "nuclide"):
        if _text(source.get(key)):
            return _text(source.get(key))
    if _text(source.get("vertices")):
        return f"vertices {Path(str(source['vertices'])).name}"
    return energy


def _surface_text(config: dict, source: dict) -> str | None:
    ref = source.get("surface")
    if isinstance(ref, str):
        return ref
    if not isinstance(ref, dict) or not _text(ref.get("face")):
        return None
    face, volume = _text(ref.get("face")), _text(ref.get("volume"))
    rough = None
    targets = config.get("targets")
    for target in targets if isinstance(targets, list) else []:
        if (
            isinstance(target, dict)
            and target.get("name") == volume
            and isinstance(target.get("rough"), list)
        ):
            rough = next(
                (r for r in target["rough"] if isinstance(r, dict) and r.get("face") == face), None
            )
    if rough is None:
        return f"flat {face}"
    surfaces = _dict(config.get("surfaces"))
    name = _text(rough.get("surface"))
    kind = _dict(surfaces.get(name)).get("kind") if name else None
    return f"rough {face}" + (f" ({kind})" if _text(kind) else "")


def describe_run(results: Results) -> str:
    """A short description from the stored configuration: emitter, face, depth profile, physics.

    Only keys that are present and of the expected type are used, so records from other score4
    versions still give a (possibly shorter) description.
    """
    config = results.run.get("config")
    config = config if isinstance(config, dict) else {}
    source = _dict(config.get("source"))
    depth = _dict(source.get("depth"))
    profile = _text(depth.get("profile"))
    parts = [
        _emitter_text(source),
        _surface_text(config, source),
        f"{profile} depth" if profile and profile != "zero" else None,
        f"{results.run['physics_mode']} physics"
        if isinstance(results.run.get("physics_mode"), str)
        else None,
    ]
    return ", ".join(p for p in parts if p)


def default_label(results: Results) -> str:
    """File stem plus :func:`describe_run`, e.g. ``"flat: alpha 5.3 MeV, flat +z of crystal"``."""
    stem = results.path.name.removesuffix(".h5").removesuffix(".hdf5")
    description = describe_run(results)
    return f"{stem}: {description}" if description else stem


# --- drawing ---------------------------------------------------------------------------------

_FORMATS = {"png", "pdf", "svg", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp"}


def _save(fig: Figure, path: str | Path) -> Path:
    path = check_output_file(path, True, "output")  # the commands check --overwrite
    fmt = path.suffix.lower().lstrip(".") or "png"
    if fmt not in _FORMATS:
        raise ConfigError(
            f"out: unknown image format {path.suffix!r} in {str(path)!r}; use one of: "
            + ", ".join(f".{f}" for f in sorted(_FORMATS))
        )
    with atomic_output(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=120)
    return path


def _as_results(item: Results | str | Path) -> Results:
    return item if isinstance(item, Results) else read_results(item)


def _labels(labels: Sequence[str] | None, n: int, what: str) -> list[str] | None:
    if labels is None:
        return None
    labels = [labels] if isinstance(labels, str) else list(labels)
    if len(labels) != n:
        raise ConfigError(
            f"labels: {len(labels)} label(s) given for {n} {what}(s); give one per {what} or none"
        )
    return labels


def _log_axis(ax, y_arrays: Iterable[np.ndarray]) -> bool:
    positive = np.concatenate(
        [np.asarray(y, dtype=float).ravel() for y in y_arrays] or [np.zeros(0)]
    )
    positive = positive[positive > 0]
    if len(positive) == 0:
        return False  # nothing to show on a log scale: stay linear
    ax.set_yscale("log")
    ax.set_ylim(positive.min() / 2, positive.max() * 2)
    return True


def line_centred_edges(edges: np.ndarray, line: float | None) -> np.ndarray:
    """Bin edges of the width of ``edges`` that put ``line`` (MeV) at a bin centre.

    The bins cover ``edges[0]`` to ``edges[-1]`` and reach at least half a bin past the top, so
    a full-energy peak at the top of the range sits inside the last bin, not on the frame.
    Without a line inside the range the grid is anchored on ``edges[0]`` instead (bin centres
    at ``edges[0] + k * width``). Edges are computed from the line, so the line sits exactly in
    the middle of its bin (no rounding splits a mono-energetic peak over two bins).
    """
    lo, hi = float(edges[0]), float(edges[-1])
    width = (hi - lo) / (len(edges) - 1)
    anchor = line if line is not None and lo <= line <= hi else lo
    below = int(np.ceil((anchor - lo) / width - 0.5 - 1e-9))  # bins under the anchor's bin
    above = int(np.ceil((hi - anchor) / width - 1e-9))  # bin centres above the anchor, to hi
    return anchor + width * (np.arange(-below, above + 2) - 0.5)


def plot_spectra(
    results_list: Results | str | Path | Sequence[Results | str | Path],
    out_png: str | Path,
    volume: str | None = None,
    bins: int | None = None,
    emin: float | str | None = None,
    emax: float | str | None = None,
    labels: Sequence[str] | None = None,
    logy: bool = True,
    per_event: bool = False,
    errors: bool = False,
) -> DrawnSpectra:
    """Draw the energy-deposit spectra of one or several runs, overlaid, and save the figure.

    Parameters
    ----------
    results_list : results (loaded or paths), one or several.
    out_png : image file; the format follows its suffix (png by default).
    volume : the volume to draw; None draws every volume of every run.
    bins, emin, emax : common binning for all runs, see
        :func:`score4.analysis.export.histogram_edges` (energies in MeV or strings with a unit).
        The bins keep that width but are shifted so the full-energy line (the largest total primary
        energy of an event) sits at a bin centre (:func:`line_centred_edges`); the x axis reaches a
        little past the last bin. The x axis is in keV when emax < 1 MeV.
    labels : one legend label per run; default :func:`default_label`. The legend also gives
        the number of events without deposit, which are not drawn.
    logy : logarithmic y axis (falls back to linear when nothing is positive).
    per_event : divide by the number of simulated events of each run, so runs of different
        sizes compare.
    errors : draw Poisson error bars (square root of the counts of each bin) at bin centres.

    Returns
    -------
    The spectra drawn: ``y`` = counts / bin width in keV (/ events if ``per_event``).
    """
    items = [results_list] if isinstance(results_list, (Results, str, Path)) else list(results_list)
    if not items:
        raise ConfigError("results: no results files to plot")
    runs = [_as_results(r) for r in items]
    given = _labels(labels, len(runs), "run")
    full = max(float(r.primary_energy.max(initial=0.0)) for r in runs)
    edges = line_centred_edges(
        histogram_edges(runs, bins=bins, emin=emin, emax=emax), full if full > 0 else None
    )
    spectra = DrawnSpectra()
    for k, res in enumerate(runs):
        names = select_volumes(res, volume)
        base = given[k] if given else default_label(res)
        for name in names:
            hist = deposit_histogram(res.edep[name], edges)
            y = hist.counts_per_keV / (max(res.n_events, 1) if per_event else 1)
            label = base if len(names) == 1 else f"{base} [{name}]"
            said = [f"{hist.n_zero} of {hist.n_events} events without deposit"] * (hist.n_zero > 0)
            said += [f"{hist.n_overflow} above range"] * (hist.n_overflow > 0)
            legend = f"{label} ({', '.join(said)})" if said else label
            spectra.append(Spectrum(label, legend, res.path, name, hist, y, per_event))
    if volume is None and any(s.hist.n_zero < s.hist.n_events for s in spectra):
        # volumes no event deposited energy in: left out of the figure, named once
        spectra.left_out = [s for s in spectra if s.hist.n_zero == s.hist.n_events]
        spectra[:] = [s for s in spectra if s.hist.n_zero < s.hist.n_events]

    in_keV = edges[-1] < 1.0
    scale = 1e3 if in_keV else 1.0
    outside = len(spectra) > LEGEND_INSIDE
    fig = Figure(figsize=(11 if outside else 8, 5), layout="constrained")
    ax = fig.add_subplot()
    centres = (edges[:-1] + edges[1:]) / 2 * scale
    one_run = len(runs) == 1 and len(spectra) > 1
    for k, s in enumerate(spectra):
        # one run of several volumes: the run's label once (title), the volumes in the legend
        entry = s.volume + s.legend[len(s.label) :] if one_run else s.legend
        style = line_style(k)
        line = ax.stairs(
            s.y,
            edges * scale,
            label=entry,
            linewidth=1.3,
            color=style["color"],
            linestyle=style["linestyle"],
        )
        if errors:
            per_count = np.divide(
                s.y, s.hist.counts, out=np.zeros_like(s.y), where=s.hist.counts > 0
            )
            shown = s.hist.counts > 0
            ax.errorbar(
                centres[shown],
                s.y[shown],
                yerr=np.sqrt(s.hist.counts[shown]) * per_count[shown],
                fmt="none",
                ecolor=line.get_edgecolor(),
                elinewidth=0.9,
                capsize=1.5,
            )
    if logy:
        _log_axis(ax, [s.y for s in spectra])
    left = max(edges[0], 0.0)
    ax.set_xlim(left * scale, (edges[-1] + 0.02 * (edges[-1] - left)) * scale)  # room past the top
    ax.set_xlabel(f"energy deposit [{'keV' if in_keV else 'MeV'}]")
    ax.set_ylabel("counts / keV / event" if per_event else "counts / keV")
    title = f"energy deposit in {volume}" if volume else "energy deposit"
    if len(runs) == 1 and len(spectra) > 1:
        title = f"{spectra[0].label[: -len(spectra[0].volume) - 3]}: {title}"
    ax.set_title(
        f"{title} ({edges[1] - edges[0]:.4g} MeV bins)"
        if not in_keV
        else f"{title} ({(edges[1] - edges[0]) * 1e3:.4g} keV bins)"
    )
    if outside:  # beside the axes, not over the spectra
        ax.legend(fontsize="x-small", loc="upper left", bbox_to_anchor=(1.01, 1.0))
    else:
        ax.legend(fontsize="small")
    notes = ["events without deposit are not drawn"]
    if spectra.left_out:
        empty = ", ".join(s.volume for s in spectra.left_out[:8])
        more = " ..." if len(spectra.left_out) > 8 else ""
        notes.append(f"volumes without any deposit left out: {empty}{more}")
    ax.set_xlabel(f"{ax.get_xlabel()}\n({'; '.join(notes)})", fontsize="small")
    ax.grid(alpha=0.3)
    _save(fig, out_png)
    return spectra


#: Most legend entries drawn inside the axes; more go beside them.
LEGEND_INSIDE = 4
_LINE_STYLES = ("-", "--", ":", "-.")


def line_style(k: int) -> dict[str, str]:
    """Colour and line style of the k-th curve: the ten tab10 colours, then the same colours
    dashed, dotted, dash-dotted (40 distinct styles before any repeats)."""
    return {"color": f"C{k % 10}", "linestyle": _LINE_STYLES[(k // 10) % len(_LINE_STYLES)]}


class DrawnSpectra(list[Spectrum]):
    """The spectra drawn, with ``left_out``: volumes no event deposited energy in (when every
    volume was asked for), which the figure leaves out and names once."""

    left_out: list[Spectrum]

    def __init__(self) -> None:
        super().__init__()
        self.left_out = []


def plot_depths(
    vertex_files_or_arrays: np.ndarray | str | Path | Sequence[np.ndarray | str | Path],
    out_png: str | Path,
    bins: int | None = None,
    dmax: float | str | None = None,
    labels: Sequence[str] | None = None,
    logy: bool = False,
) -> list[DepthHistogram]:
    """Histogram vertex depths below the surface, in nm, and save the figure.

    Parameters
    ----------
    vertex_files_or_arrays : one or several 1-D arrays of depths **in mm**, or vertex files
        (HDF5 with a dataset ``vertices/depth``, see :func:`read_vertex_depths`).
    out_png : image file; the format follows its suffix.
    bins : number of bins (default 100), common to all inputs.
    dmax : upper edge, mm or a string with a unit (``"50 nm"``); default the largest depth.
    labels : one legend label per input; default the file stem, or ``"depths <k>"``.
    logy : logarithmic y axis.

    Returns
    -------
    The histograms drawn (vertices per bin and per nm; edges in nm; values outside the range
    are not counted).
    """
    if isinstance(vertex_files_or_arrays, (str, Path, np.ndarray)):
        items = [vertex_files_or_arrays]
    else:
        items = list(vertex_files_or_arrays)
    if not items:
        raise ConfigError("depths: nothing to plot")
    if isinstance(vertex_files_or_arrays, np.ndarray) and vertex_files_or_arrays.ndim != 1:
        raise ConfigError(
            "depths: expected a 1-D array of depths in mm, got shape "
            f"{vertex_files_or_arrays.shape}"
        )
    given = _labels(labels, len(items), "input")
    data, names = [], []
    for k, item in enumerate(items):
        if isinstance(item, (str, Path)):
            depths, name = read_vertex_depths(item), Path(item).name.removesuffix(".h5")
        else:
            depths, name = np.asarray(item, dtype=float), f"depths {k + 1}"
            if depths.ndim != 1:
                raise ConfigError(
                    f"depths: expected a 1-D array of depths in mm, got shape {depths.shape}"
                )
        if not np.isfinite(depths).all():
            raise ConfigError(f"depths: {name} holds non-finite values")
        data.append(depths * 1e6)  # nm
        names.append(given[k] if given else name)
    check_bins(bins)
    if isinstance(dmax, str):
        from score4.common.units import parse_quantity

        dmax = parse_quantity(dmax, "length", "dmax")
    everything = np.concatenate(data)
    lo = min(0.0, float(everything.min(initial=0.0)))
    if dmax is not None:
        hi = float(dmax) * 1e6
        if not hi > lo:
            raise ConfigError(
                f"dmax: must be larger than the smallest depth ({lo / 1e6!r} mm), got {dmax!r} mm"
            )
    else:
        hi = float(everything.max(initial=0.0))
        if not hi > lo:
            hi = lo + 1.0  # all depths equal (e.g. all on the surface): a 1 nm range
    edges = np.linspace(lo, hi, int(bins or 100) + 1)
    hists = []
    for name, d in zip(names, data, strict=True):
        counts, _ = np.histogram(d, bins=edges)
        hists.append(DepthHistogram(name, edges, counts, counts / np.diff(edges)))

    fig = Figure(figsize=(8, 5), layout="constrained")
    ax = fig.add_subplot()
    for h, d in zip(hists, data, strict=True):
        ax.stairs(h.per_nm, edges, label=f"{h.label} ({len(d)} vertices)", linewidth=1.3)
    if logy:
        _log_axis(ax, [h.per_nm for h in hists])
    ax.set_xlim(edges[0], edges[-1])
    ax.set_xlabel("depth below the surface [nm]")
    ax.set_ylabel("vertices / nm")
    ax.set_title("vertex depths")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    _save(fig, out_png)
    return hists


@dataclass(frozen=True)
class RangeDepths:
    """Drawn depth histograms of stopped ions: ``density`` per nm (integral 1) on ``edges_nm``."""

    labels: list[str]
    edges_nm: np.ndarray
    density: list[np.ndarray]
    stopped: list[int]


def plot_range_depths(
    samples: dict, path: str | Path, title: str, bins: int | None = None
) -> RangeDepths:
    """Depth distributions of the stopped ions of several range samples (``RangeSample``).

    ``samples`` maps a legend label (``"score4"``, ``"TRIM"``) to a sample; all share the same
    bins, which span the stopped ions' depths (5 % margins), and each is normalised to unit
    area over depth, so shapes compare directly. Depths are drawn in nm, or in um beyond 10 um.
    """
    depths = {k: s.final_position[s.stopped, 2] * 1e6 for k, s in samples.items()}
    every = np.concatenate([*depths.values(), np.zeros(0)])
    if bins is None:  # about sqrt(n) bins for the smallest sample, 20 to 60
        smallest = min((len(d) for d in depths.values() if len(d)), default=400)
        bins = int(np.clip(np.sqrt(smallest), 20, 60))
    lo, hi = (float(every.min()), float(every.max())) if len(every) else (0.0, 1.0)
    margin = 0.05 * (hi - lo) if hi > lo else max(abs(hi), 1.0) * 0.05
    edges = np.linspace(max(0.0, lo - margin), hi + margin, bins + 1)
    scale, unit = (1e-3, "um") if edges[-1] > 1e4 else (1.0, "nm")
    fig = Figure(figsize=(7, 4.5))
    ax = fig.add_subplot()
    drawn = []
    for (label, d), style in zip(depths.items(), ("-", "--", ":", "-."), strict=False):
        density = np.histogram(d, edges, density=True)[0] if len(d) else np.zeros(bins)
        drawn.append(density)
        n_all = samples[label].events
        ax.stairs(
            density / scale,
            edges * scale,
            linestyle=style,
            linewidth=1.6,
            label=f"{label} ({len(d)} of {n_all} ions stopped)",
        )
    ax.set_xlabel(f"depth below the entrance face z ({unit})")
    ax.set_ylabel(f"stopped ions per {unit} (normalised to 1)")
    ax.set_title(title)
    ax.set_xlim(edges[0] * scale, edges[-1] * scale)
    top = max((float(d.max()) for d in drawn if len(d)), default=0.0) / scale
    ax.set_ylim(0, 1.3 * top if top > 0 else 1.0)
    ax.legend(loc="upper right", fontsize="small")
    fig.tight_layout()
    _save(fig, path)
    return RangeDepths(list(depths), edges, drawn, [len(d) for d in depths.values()])


# --- templates and models ------------------------------------------------------------------------


@dataclass(frozen=True)
class StackComponent:
    """One layer of a stacked spectrum: ``values`` per bin on ``edges_kev`` (any rate unit)."""

    label: str
    edges_kev: np.ndarray
    values: np.ndarray


def _mark_roi(ax, roi_kev: tuple[float, float] | None, scale: float) -> None:
    if roi_kev is not None:
        ax.axvspan(
            roi_kev[0] * scale, roi_kev[1] * scale, color="0.6", alpha=0.25, lw=0, label="ROI"
        )


def _energy_scale(edges_kev: np.ndarray) -> tuple[float, str]:
    """Draw in MeV when the range passes 2 MeV, else in keV."""
    return (1e-3, "MeV") if edges_kev[-1] > 2000 else (1.0, "keV")


def draw_stack(ax, components: Sequence[StackComponent], roi_kev=None) -> np.ndarray:
    """Stack ``components`` (first at the bottom) as filled steps on ``ax``; return the total."""
    edges = components[0].edges_kev
    scale, unit = _energy_scale(edges)
    bottom = np.zeros(len(edges) - 1)
    for c in components:
        top = bottom + c.values
        ax.stairs(top, edges * scale, baseline=bottom, fill=True, alpha=0.75, label=c.label)
        bottom = top
    ax.stairs(bottom, edges * scale, color="k", lw=0.8, label="total")
    _mark_roi(ax, roi_kev, scale)
    _log_axis(ax, [bottom])
    ax.set_xlim(edges[0] * scale, edges[-1] * scale)
    ax.set_xlabel(f"energy [{unit}]")
    ax.grid(alpha=0.3)
    return bottom


def plot_stacked(
    panels: dict[str, Sequence[StackComponent]],
    out: str | Path,
    ylabel: str = "counts / (keV kg day)",
    roi_kev: tuple[float, float] | None = None,
    title: str = "",
) -> dict[str, np.ndarray]:
    """One panel per detector, components stacked on a log axis, the ROI shaded; returns the
    total of each panel."""
    if not panels:
        raise ConfigError("plot: no templates to draw")
    fig = Figure(figsize=(8, 3.6 * len(panels) + 0.6), layout="constrained")
    totals = {}
    for k, (name, components) in enumerate(panels.items()):
        ax = fig.add_subplot(len(panels), 1, k + 1)
        totals[name] = draw_stack(ax, components, roi_kev)
        ax.set_ylabel(ylabel)
        ax.set_title(f"{title} {name}".strip())
        ax.legend(fontsize="small")
    _save(fig, out)
    return totals


def plot_templates(ts, out: str | Path) -> dict[str, np.ndarray]:
    """A templates set (:class:`score4.analysis.templates.TemplateSet`): per detector, its M1 and M2
    templates stacked (their sum is the ``all`` template, with M3+ on top), on a log axis."""
    panels: dict[str, Sequence[StackComponent]] = {}
    for d in ts.detectors:
        kinds = ts.final.detectors[d]
        rest = kinds["all"].rate - kinds["m1"].rate - kinds["m2"].rate
        layers = [("M1", kinds["m1"].rate), ("M2", kinds["m2"].rate)]
        if (rest > 1e-12 * kinds["all"].rate.max(initial=0)).any():
            layers.append(("M3+", rest))
        panels[d] = [StackComponent(label, ts.edges_kev, values) for label, values in layers]
    return plot_stacked(
        panels, out, roi_kev=ts.roi_kev, title=f"{ts.activity.text}, {ts.final.name}:"
    )


def plot_fit(
    edges_kev: np.ndarray,
    data: np.ndarray,
    components: Sequence[StackComponent],
    out: str | Path,
    roi_kev: tuple[float, float] | None = None,
    title: str = "",
) -> np.ndarray:
    """Data (points, Poisson errors) over the fitted model (stacked), residuals below in units
    of the Poisson error of the model; returns the residuals."""
    fig = Figure(figsize=(8, 6.5), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(3, 1))
    total = draw_stack(top, components, roi_kev)
    scale, _ = _energy_scale(edges_kev)
    centres = (edges_kev[:-1] + edges_kev[1:]) / 2 * scale
    shown = data > 0
    top.errorbar(
        centres[shown],
        data[shown],
        yerr=np.sqrt(data[shown]),
        fmt="o",
        ms=2.5,
        color="k",
        elinewidth=0.8,
        label="data",
    )
    _log_axis(top, [total, data])
    top.set_ylabel("counts per bin")
    top.set_xlabel("")
    top.set_title(title)
    top.legend(fontsize="small")
    residual = np.divide(data - total, np.sqrt(total), out=np.zeros_like(total), where=total > 0)
    bottom.stairs(residual, edges_kev * scale, color="k", lw=0.8)
    bottom.axhline(0, color="0.5", lw=0.8)
    _mark_roi(bottom, roi_kev, scale)
    bottom.set_ylabel("(data - model) / sqrt(model)")
    bottom.set_xlabel(top.get_xlabel() or f"energy [{_energy_scale(edges_kev)[1]}]")
    bottom.grid(alpha=0.3)
    _save(fig, out)
    return residual
