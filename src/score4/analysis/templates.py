"""Templates: counts per keV per kg per day in each detector for a given contamination.

A template turns a run's deposits into what a background model fits. For a source of total
activity ``A`` (Bq) simulated with ``N`` decays (the run record's ``simulated_decays``), every
simulated event stands for ``A / N`` decays per second, so an event seen in a detector of mass
``m`` adds

    ``f = A / N * 86400 / m``  counts per kg per day,

and a bin of width ``dE`` keV holding ``n`` events is ``n f / dE`` counts/(keV kg day), with the
Monte Carlo error ``sqrt(sum of squared event weights) f / dE`` (``sqrt(n) f / dE``: every
event has weight 1 here).

The total activity comes from the activity the user quotes and the run record's source
(:func:`source_activity`): per area (``Bq/cm2``) for a surface source, times the **true rough
area that was sampled** (``source.area_mm2``; decays are drawn uniformly per true area, so a
contamination per unit of true area multiplies the true area, not the projected one); per mass
(``Bq/kg``) or per volume (``Bq/cm3``) for a bulk source, times its mass or volume; in total
(``Bq``) only for a vertex file whose area or mass is unknown.

Per detector and stage (``deposit``: the energy deposited, seen when > 0; ``visible``: after the
detector response of :mod:`score4.analysis.response`, seen above its threshold):

* ``all``: every event the detector sees; ``m1``: events that only this detector sees;
  ``m2``: events seen by exactly two detectors (this one's energy);
* ``m2_sum``: the summed energy of the two detectors of every M2 event, per kg of all
  detectors together; ``pairs/<a>__<b>``: the 2-D histogram (energy in ``a``, energy in ``b``)
  of the M2 events of that pair, counts/(keV^2 kg day) per kg of all detectors together.

Energies are in keV in the files. The HDF5 file holds every histogram as an LH5 ``Histogram``
(legend-pydataobj's layout: ``binning/axis_0/binedges`` with ``units: keV``, ``weights``,
``isdensity``), with siblings ``<name>_error`` (1 sigma, same units) and ``<name>_counts``
(simulated events per bin); ``lh5.read("deposit/detectors/crystal/all", file)`` reads one and
``.view_as("hist")`` gives a :class:`hist.Hist`. The ROOT file holds TH1D/TH2D (uproot) with
the errors in ``fSumw2``.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from score4.errors import ConfigError
from score4.files import atomic_output, check_output_file, open_h5
from score4.inputs import limits
from score4.inputs.units import format_readable, parse_activity, parse_quantity
from score4.runner.output import Results

from .export import histogram_edges
from .response import ResponseConfig, apply_response, needs_split, response_to_dict

FORMAT = "score4-templates"
FORMAT_VERSION = 1
SECONDS_PER_DAY = 86400.0
RATE_UNIT = "counts/(keV kg day)"
TOP_TOLERANCE = 1e-9  # relative: deposits this close above the top edge count in the top bin
KINDS = ("all", "m1", "m2")

_NEEDS = ("volumes", "source", "simulated_decays")
_KIND_NAME = {"area": "per area", "mass": "per mass", "volume": "per volume", "total": "in total"}


# --- normalisation ------------------------------------------------------------------------------


def require_normalisation(results: Results) -> None:
    """Raise ConfigError unless the run record holds the normalisation entries."""
    missing = [k for k in _NEEDS if k not in results.run]
    if missing:
        raise ConfigError(
            f"{results.path}: the run record has no normalisation data ({', '.join(missing)}: "
            "simulated decays, the sampled area and the detector masses); the file was written by "
            "an older score4. Run its configuration again with this score4 (the configuration is "
            f"stored in the file: score4 export {results.path.name} --root ... shows it; or "
            "score4 run CONFIG.yaml --out NEW.h5)"
        )


@dataclass(frozen=True)
class SourceActivity:
    """A quoted activity turned into the total activity of the simulated source."""

    text: str  # as given ("1 mBq/cm2")
    kind: str  # area | mass | volume | total
    value: float  # Bq/mm2, Bq/kg, Bq/mm3 or Bq
    size: float  # area mm2, mass kg, volume mm3, or 1
    size_text: str  # what was multiplied, in words
    total_bq: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "text": self.text,
            "kind": self.kind,
            "value": self.value,
            "unit": {"area": "Bq/mm2", "mass": "Bq/kg", "volume": "Bq/mm3", "total": "Bq"}[
                self.kind
            ],
            "multiplied_by": self.size_text,
            "total_Bq": self.total_bq,
        }


def _source_kind(source: dict) -> str:
    """surface, bulk or vertices; a vertex file drawn by ``score4 vertices`` is what it was drawn
    from."""
    kind = str(source.get("kind"))
    if kind == "vertices" and source.get("drawn_from"):
        return str(source["drawn_from"])
    return kind


def source_activity(run: dict, text: str) -> SourceActivity:
    """The total activity (Bq) of the run's source for a quoted activity (see the module notes).

    Raises ConfigError when the activity's unit does not fit the source kind.
    """
    kind, value = parse_activity(text, "--activity")
    if not value > 0:
        raise ConfigError(f"--activity: must be greater than 0, got {text!r}")
    source = run["source"]
    source_kind = _source_kind(source)
    where = f"{source.get('volume')} {source.get('face') or ''}".rstrip()
    if source_kind == "surface":
        if kind != "area":
            raise ConfigError(
                f"--activity: {text!r} is an activity {_KIND_NAME[kind]}; the run's source is a "
                f"surface source ({where}): give an activity per area, e.g. '1 mBq/cm2'"
            )
        area = float(source["area_mm2"])
        return SourceActivity(
            text,
            kind,
            value,
            area,
            f"true sampled area {format_readable(area, 'area')} (projected "
            f"{format_readable(float(source['projected_area_mm2']), 'area')})",
            value * area,
        )
    if source_kind == "bulk":
        if kind == "mass" and source.get("mass_kg") is not None:
            mass = float(source["mass_kg"])
            return SourceActivity(
                text, kind, value, mass, f"mass {mass:.6g} kg of {source['volume']}", value * mass
            )
        if kind == "volume" and source.get("volume_mm3") is not None:
            vol = float(source["volume_mm3"])
            return SourceActivity(
                text, kind, value, vol, f"volume {vol:.6g} mm3 of {source['volume']}", value * vol
            )
        raise ConfigError(
            f"--activity: {text!r} is an activity {_KIND_NAME[kind]}; the run's source fills the "
            f"volume {source.get('volume')}: give an activity per mass ('5 mBq/kg') or per volume "
            "('1 Bq/cm3')"
        )
    # a vertex file whose area or mass nobody knows: only a total activity means something
    if kind != "total":
        raise ConfigError(
            f"--activity: {text!r} is an activity {_KIND_NAME[kind]}, but the run's vertex file "
            f"{source.get('file')} does not say which area or mass its vertices cover (it was not "
            "drawn by score4 vertices): give the total activity of the vertices, e.g. '2 Bq'"
        )
    return SourceActivity(text, kind, value, 1.0, "the vertex file's total activity", value)


def detector_masses(run: dict, detectors: list[str]) -> dict[str, float]:
    """{detector: mass kg} from the run record; ConfigError for an unknown mass."""
    known = {v["name"]: v for v in run["volumes"]}
    out = {}
    for name in detectors:
        if name not in known:
            raise ConfigError(f"{name}: the run record's volumes have no entry for this column")
        mass = known[name].get("mass_kg")
        if mass is None or not mass > 0:
            raise ConfigError(
                f"{name}: the run record has no mass for this volume (material "
                f"{known[name].get('material')!r} has no known density)"
            )
        out[name] = float(mass)
    return out


def select_detectors(results: Results, detectors: list[str] | None) -> list[str]:
    """The detectors (scored volumes) templates are made for: all, or those named (checked)."""
    names = list(results.edep)
    if not detectors:
        return names
    unknown = [d for d in detectors if d not in names]
    if unknown:
        raise ConfigError(
            f"--detector: {', '.join(map(repr, unknown))} is not a volume of {results.path}; "
            f"volumes are: {', '.join(names)}"
        )
    return list(dict.fromkeys(detectors))


# --- histograms ---------------------------------------------------------------------------------


@dataclass
class Template:
    """One histogram: ``rate`` and ``error`` in counts/(keV kg day) (2-D: per keV^2), ``counts``
    simulated events per bin; ``edges`` in keV (one array per axis)."""

    name: str
    edges: list[np.ndarray]
    rate: np.ndarray
    error: np.ndarray
    counts: np.ndarray
    mass_kg: float
    title: str
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def unit(self) -> str:
        return RATE_UNIT if len(self.edges) == 1 else "counts/(keV^2 kg day)"


def _fold_top(values: np.ndarray, top: float) -> np.ndarray:
    at_top = (values > top) & (values <= top * (1 + TOP_TOLERANCE))
    return np.where(at_top, top, values)


def _histogram(
    name: str,
    title: str,
    values: list[np.ndarray],
    edges_mev: np.ndarray,
    weight: float,
    mass: float,
) -> Template:
    """Rate histogram of events (``values``: one array per axis, MeV); ``weight`` = f per event."""
    sample = [_fold_top(v, edges_mev[-1]) for v in values]
    counts, _ = np.histogramdd(np.column_stack(sample), bins=[edges_mev] * len(sample))
    widths = np.diff(edges_mev) * 1e3
    width = widths if len(sample) == 1 else np.multiply.outer(widths, widths)
    return Template(
        name=name,
        edges=[edges_mev * 1e3] * len(sample),
        rate=counts * weight / width,
        error=np.sqrt(counts) * weight / width,  # event weights are 1: sum of squares = counts
        counts=counts,
        mass_kg=mass,
        title=title,
    )


@dataclass
class Stage:
    """The templates of one stage (``deposit`` or ``visible``)."""

    name: str
    detectors: dict[str, dict[str, Template]]  # detector -> kind -> template
    m2_sum: Template
    pairs: dict[tuple[str, str], Template]
    totals: dict[str, dict[str, Any]]  # detector -> rates (counts/(kg day)) and counts


def build_stage(
    name: str,
    energies: dict[str, np.ndarray],
    edges_mev: np.ndarray,
    per_event: float,
    masses: dict[str, float],
    roi: tuple[float, float] | None = None,
) -> Stage:
    """Templates of one stage from per-event energies (MeV, 0 = not seen) per detector.

    ``per_event`` is ``A / N * 86400`` (decays per day per simulated event).
    """
    names = list(energies)
    e = np.column_stack([energies[d] for d in names]) if names else np.zeros((0, 0))
    seen = e > 0
    multiplicity = seen.sum(axis=1)
    detectors, totals = {}, {}
    for k, d in enumerate(names):
        f = per_event / masses[d]
        masks = {
            "all": seen[:, k],
            "m1": seen[:, k] & (multiplicity == 1),
            "m2": seen[:, k] & (multiplicity == 2),
        }
        detectors[d] = {
            kind: _histogram(
                f"{d}/{kind}", f"{name} {kind} {d}", [e[mask, k]], edges_mev, f, masses[d]
            )
            for kind, mask in masks.items()
        }
        totals[d] = _totals(e[:, k], masks, f, roi)
    total_mass = float(sum(masses[d] for d in names))
    m2 = multiplicity == 2
    f_all = per_event / total_mass
    m2_sum = _histogram(
        "m2_sum", f"{name} M2 sum energy", [e[m2].sum(axis=1)], edges_mev, f_all, total_mass
    )
    pairs = {}
    for i, j in itertools.combinations(range(len(names)), 2):
        both = m2 & seen[:, i] & seen[:, j]
        if both.any():
            a, b = names[i], names[j]
            pairs[(a, b)] = _histogram(
                f"pairs/{a}__{b}",
                f"{name} M2 {a} vs {b}",
                [e[both, i], e[both, j]],
                edges_mev,
                f_all,
                total_mass,
            )
    return Stage(name, detectors, m2_sum, pairs, totals)


def _totals(
    e: np.ndarray, masks: dict[str, np.ndarray], f: float, roi: tuple[float, float] | None
) -> dict[str, Any]:
    """Rates of one detector in counts/(kg day) (whatever the energy) and in the ROI."""
    out: dict[str, Any] = {}
    for kind, mask in masks.items():
        n = int(mask.sum())
        prefix = "" if kind == "all" else f"{kind}_"
        out[f"{prefix}simulated_counts"] = n
        out[f"{prefix}counts_per_kg_day"] = n * f
        out[f"{prefix}counts_per_kg_day_error"] = np.sqrt(n) * f
    if roi is not None:
        lo, hi = roi
        width = (hi - lo) * 1e3
        for kind, mask in masks.items():
            n = int((mask & (e >= lo) & (e < hi)).sum())
            prefix = "" if kind == "all" else f"{kind}_"
            out[f"{prefix}roi_simulated_counts"] = n
            out[f"{prefix}roi_counts_per_keV_kg_day"] = n * f / width
            out[f"{prefix}roi_counts_per_keV_kg_day_error"] = np.sqrt(n) * f / width
    return out


@dataclass
class TemplateSet:
    """Everything ``score4 template`` makes from one results file."""

    results: str
    detectors: list[str]
    masses: dict[str, float]
    activity: SourceActivity
    simulated_decays: float  # decays of activity_nuclide (a chain: of its head)
    activity_nuclide: str | None
    source: dict
    livetime_s: float | None
    edges_kev: np.ndarray
    stages: dict[str, Stage]
    response: dict | None
    roi_kev: tuple[float, float] | None
    energy: str = "edep"  # active_edep: the run's active energy (targets[].activeness)

    @property
    def final(self) -> Stage:
        """The stage a user quotes: after the response if there is one."""
        return self.stages.get("visible", self.stages["deposit"])

    def normalisation(self) -> dict[str, Any]:
        """The normalisation inputs, as stored in the file."""
        return {
            "results_file": self.results,
            "simulated_decays": self.simulated_decays,
            "activity": self.activity.to_dict(),
            "activity_nuclide": self.activity_nuclide,
            "source": self.source,
            "area_used": (
                "the true (rough) area the vertices were sampled on: decays are uniform per true "
                "area"
                if self.activity.kind == "area"
                else None
            ),
            "detector_masses_kg": self.masses,
            "livetime_s": self.livetime_s,
            "seconds_per_day": SECONDS_PER_DAY,
            "rate_unit": RATE_UNIT,
            "energy_unit": "keV",
            "roi_keV": list(self.roi_kev) if self.roi_kev else None,
            "response": self.response,
            "energy": self.energy,
            "formula": "rate = counts * total_activity_Bq / simulated_decays * 86400 / mass_kg "
            "/ bin_width_keV",
        }

    def to_json(self) -> dict[str, Any]:
        """The machine-readable summary (``score4 template --json``)."""
        detectors = {}
        for d in self.detectors:
            entry: dict[str, Any] = {"mass_kg": self.masses[d], **self.final.totals[d]}
            if self.livetime_s is not None:
                days = self.livetime_s / SECONDS_PER_DAY
                entry["expected_counts"] = entry["counts_per_kg_day"] * self.masses[d] * days
            if "visible" in self.stages:
                entry["before_response"] = self.stages["deposit"].totals[d]
            detectors[d] = entry
        return {
            "results": self.results,
            "stage": self.final.name,
            "simulated_decays": self.simulated_decays,
            "activity": self.activity.to_dict(),
            "activity_nuclide": self.activity_nuclide,
            "livetime_s": self.livetime_s,
            "bins": len(self.edges_kev) - 1,
            "energy_range_keV": [float(f"{self.edges_kev[i]:.12g}") for i in (0, -1)],
            "roi_keV": list(self.roi_kev) if self.roi_kev else None,
            "response": self.response,
            "energy": self.energy,
            "detectors": detectors,
        }


def build_templates(
    results: Results,
    activity: str,
    *,
    detectors: list[str] | None = None,
    bins: int | None = None,
    emin: float | str | None = None,
    emax: float | str | None = None,
    response: ResponseConfig | None = None,
    livetime: str | None = None,
    roi: tuple[str, str] | None = None,
) -> TemplateSet:
    """Templates of a results file for a quoted ``activity`` ("1 mBq/cm2"); see the module notes.

    ``response`` adds the ``visible`` stage; ``livetime`` ("1 yr") adds expected counts;
    ``roi`` (two energies, "2 MeV", "3 MeV") adds the rates in that window. Every check comes
    before any work: unknown detectors, activity units, response needs, energy windows.
    """
    require_normalisation(results)
    names = select_detectors(results, detectors)
    masses = detector_masses(results.run, names)
    act = source_activity(results.run, activity)
    live = None if livetime is None else parse_quantity(livetime, "time", "--livetime") * 1e-9
    if live is not None and not live > 0:
        raise ConfigError(f"--livetime: must be greater than 0, got {livetime!r}")
    window = _roi(roi)
    if response is not None and needs_split(response) and "edep_alpha" not in results.scores:
        raise ConfigError(
            "response.quenching: quenching factors need the deposits split by particle class, "
            f"which {results.path} lacks; run again with output: {{split_by_particle: true}}"
        )
    edges = histogram_edges(results, bins=bins, emin=emin, emax=emax)
    if window is not None and not (
        edges[0] - 1e-9 <= window[0] and window[1] <= edges[-1] * (1 + 1e-9) + 1e-12
    ):
        raise ConfigError(
            f"--roi: {window[0] * 1e3:.6g} to {window[1] * 1e3:.6g} keV is not inside the "
            "templates' energy range, "
            f"{edges[0] * 1e3:.6g} to {edges[-1] * 1e3:.6g} keV (set --emin/--emax to cover it)"
        )
    n_stages, n_det = 1 + (response is not None), len(names)
    limits.check_bins(  # per stage: a few 1D kinds per detector, the sum, a 2D one per pair
        len(edges) - 1,
        "bins",
        n_1d=n_stages * (4 * n_det + 1),
        n_2d=n_stages * n_det * (n_det - 1) // 2,
        hint="use fewer bins or fewer --detector",
    )
    n = float(results.run["simulated_decays"])
    per_event = act.total_bq / n * SECONDS_PER_DAY
    stages = {
        "deposit": build_stage(
            "deposit", {d: results.detected[d] for d in names}, edges, per_event, masses, window
        )
    }
    if response is not None:
        visible = apply_response(results.scores, names, response)
        stages["visible"] = build_stage("visible", visible, edges, per_event, masses, window)
    return TemplateSet(
        results=str(results.path),
        detectors=names,
        masses=masses,
        activity=act,
        simulated_decays=n,
        activity_nuclide=results.run.get("activity_nuclide"),
        source=results.run["source"],
        livetime_s=live,
        edges_kev=edges * 1e3,
        stages=stages,
        response=None if response is None else response_to_dict(response),
        roi_kev=None if window is None else (window[0] * 1e3, window[1] * 1e3),
        energy="active_edep" if results.active else "edep",
    )


def _roi(roi: tuple[str, str] | None) -> tuple[float, float] | None:
    if roi is None:
        return None
    lo, hi = (parse_quantity(v, "energy", "--roi") for v in roi)
    if not (0 <= lo < hi):
        raise ConfigError(f"--roi: need 0 <= low < high, got {roi[0]!r} {roi[1]!r}")
    return lo, hi


# --- files --------------------------------------------------------------------------------------


def _scalar(group: h5py.Group, name: str, value: Any, units: str | None = None) -> None:
    if isinstance(value, str):
        d = group.create_dataset(name, data=value.encode())
        d.attrs["datatype"] = "string"
    else:
        d = group.create_dataset(name, data=value)
        d.attrs["datatype"] = "bool" if isinstance(value, bool) else "real"
    if units:
        d.attrs["units"] = units


def _struct(group: h5py.Group) -> None:
    group.attrs["datatype"] = "struct{" + ",".join(group) + "}"


def _write_histogram(
    parent: h5py.Group,
    name: str,
    edges: list[np.ndarray],
    weights: np.ndarray,
    unit: str,
    density: bool,
    attrs: dict[str, Any],
) -> None:
    """One LH5 ``Histogram`` (legend-pydataobj layout) with variable bin edges in keV."""
    g = parent.create_group(name)
    binning = g.create_group("binning")
    for k, e in enumerate(edges):
        axis = binning.create_group(f"axis_{k}")
        be = axis.create_dataset("binedges", data=np.asarray(e, float))
        be.attrs["datatype"] = "array<1>{real}"
        be.attrs["units"] = "keV"
        _scalar(axis, "closedleft", True)
        _struct(axis)
    _struct(binning)
    w = g.create_dataset("weights", data=np.asarray(weights, float))
    w.attrs["datatype"] = f"array<{w.ndim}>{{real}}"
    _scalar(g, "isdensity", density)
    g.attrs["datatype"] = "struct{binning,isdensity,weights}"
    g.attrs["units"] = unit
    for key, value in attrs.items():
        g.attrs[key] = value


def _write_template(parent: h5py.Group, name: str, t: Template, livetime_s: float | None) -> None:
    info = {"title": t.title, "mass_kg": t.mass_kg}
    _write_histogram(parent, name, t.edges, t.rate, t.unit, True, info)
    _write_histogram(parent, f"{name}_error", t.edges, t.error, t.unit, True, info)
    _write_histogram(parent, f"{name}_counts", t.edges, t.counts, "simulated events", False, info)
    if livetime_s is not None:  # expected counts per bin in the live time
        width = np.diff(t.edges[0])
        if len(t.edges) == 2:
            width = np.multiply.outer(width, np.diff(t.edges[1]))
        expected = t.rate * width * t.mass_kg * livetime_s / SECONDS_PER_DAY
        _write_histogram(parent, f"{name}_expected", t.edges, expected, "counts", False, info)


def write_templates_h5(ts: TemplateSet, path: str | Path) -> Path:
    """Write the templates as LH5 histograms (see the module notes), atomically."""
    path = check_output_file(path, True, "--out")  # the command checks --overwrite
    with atomic_output(path) as tmp, h5py.File(tmp, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        norm = f.create_group("normalisation")
        norm.attrs["json"] = json.dumps(ts.normalisation())
        _scalar(norm, "simulated_decays", ts.simulated_decays)
        _scalar(norm, "activity_total", ts.activity.total_bq, "Bq")
        _scalar(norm, "activity", ts.activity.text)
        if ts.activity.kind == "area":
            _scalar(norm, "area", float(ts.source["area_mm2"]), "mm2")
            _scalar(norm, "projected_area", float(ts.source["projected_area_mm2"]), "mm2")
        if ts.livetime_s is not None:
            _scalar(norm, "livetime", ts.livetime_s, "s")
        masses = norm.create_group("mass")
        for d, m in ts.masses.items():
            _scalar(masses, d, m, "kg")
        _struct(masses)
        _struct(norm)
        for stage in ts.stages.values():
            g = f.create_group(stage.name)
            dets = g.create_group("detectors")
            for d, kinds in stage.detectors.items():
                dg = dets.create_group(d)
                for kind, t in kinds.items():
                    _write_template(dg, kind, t, ts.livetime_s)
                _scalar(dg, "rate", stage.totals[d]["counts_per_kg_day"], "counts/(kg day)")
                _scalar(
                    dg, "rate_error", stage.totals[d]["counts_per_kg_day_error"], "counts/(kg day)"
                )
                _struct(dg)
            _struct(dets)
            _write_template(g, "m2_sum", stage.m2_sum, ts.livetime_s)
            pairs = g.create_group("pairs")
            for (a, b), t in stage.pairs.items():
                _write_template(pairs, f"{a}__{b}", t, ts.livetime_s)
            _struct(pairs)
            _struct(g)
        _struct(f)
    return path


def _th1d(name: str, t: Template):
    from uproot.writing.identify import to_TAxis, to_TH1x

    edges = t.edges[0]
    axis = to_TAxis(
        "xaxis",
        "energy [keV]",
        len(edges) - 1,
        float(edges[0]),
        float(edges[-1]),
        fXbins=edges.astype(np.float64),
    )
    data = np.concatenate([[0.0], t.rate, [0.0]])
    var = np.concatenate([[0.0], t.error**2, [0.0]])
    return to_TH1x(
        name,
        f"{t.title} [{t.unit}]",
        data,
        fEntries=float(t.counts.sum()),
        fTsumw=float(t.rate.sum()),
        fTsumw2=float(var.sum()),
        fTsumwx=0.0,
        fTsumwx2=0.0,
        fSumw2=var,
        fXaxis=axis,
    )


def _th2d(name: str, t: Template):
    from uproot.writing.identify import to_TAxis, to_TH2x

    ex, ey = t.edges
    ax = to_TAxis("xaxis", "energy [keV]", len(ex) - 1, float(ex[0]), float(ex[-1]), fXbins=ex)
    ay = to_TAxis("yaxis", "energy [keV]", len(ey) - 1, float(ey[0]), float(ey[-1]), fXbins=ey)
    # ROOT stores 2-D contents with under/overflow, x fastest
    data = np.zeros((len(ey) + 1, len(ex) + 1))
    var = np.zeros_like(data)
    data[1:-1, 1:-1] = t.rate.T
    var[1:-1, 1:-1] = (t.error**2).T
    return to_TH2x(
        name,
        f"{t.title} [{t.unit}]",
        data.ravel(),
        fEntries=float(t.counts.sum()),
        fTsumw=float(t.rate.sum()),
        fTsumw2=float(var.sum()),
        fTsumwx=0.0,
        fTsumwx2=0.0,
        fTsumwy=0.0,
        fTsumwy2=0.0,
        fTsumwxy=0.0,
        fSumw2=var.ravel(),
        fXaxis=ax,
        fYaxis=ay,
    )


def root_names(ts: TemplateSet) -> dict[str, Template]:
    """{ROOT object name: template}: ``<stage>_<detector>_<kind>``, ``<stage>_m2_sum``,
    ``<stage>_pair_<a>__<b>``."""
    out = {}
    for stage in ts.stages.values():
        for d, kinds in stage.detectors.items():
            for kind, t in kinds.items():
                out[f"{stage.name}_{d}_{kind}"] = t
        out[f"{stage.name}_m2_sum"] = stage.m2_sum
        for (a, b), t in stage.pairs.items():
            out[f"{stage.name}_pair_{a}__{b}"] = t
    return out


def write_templates_root(ts: TemplateSet, path: str | Path) -> Path:
    """Write the templates as ROOT TH1D/TH2D (rates, errors in fSumw2) plus the normalisation
    as a TObjString ``normalisation`` (JSON)."""
    import uproot

    path = check_output_file(path, True, "--root")
    with atomic_output(path) as tmp, uproot.recreate(tmp) as f:
        for name, t in root_names(ts).items():
            f[name] = _th1d(name, t) if len(t.edges) == 1 else _th2d(name, t)
        f["normalisation"] = json.dumps(ts.normalisation())
    return path


# --- reading ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StoredTemplate:
    """One 1-D template read back from a templates file."""

    file: Path
    stage: str
    detector: str
    kind: str
    edges_kev: np.ndarray
    rate: np.ndarray
    error: np.ndarray
    mass_kg: float
    normalisation: dict

    @property
    def activity(self) -> dict:
        return self.normalisation["activity"]


def read_template(
    path: str | Path, detector: str | None = None, kind: str = "all", stage: str | None = None
) -> StoredTemplate:
    """A template of a templates file: ``detector`` (default: the only one), ``kind`` (all, m1,
    m2, m2_sum), ``stage`` (default: visible if the file has it, else deposit)."""
    path = Path(path)
    with open_h5(path, FORMAT, "templates", ConfigError) as f:
        norm = json.loads(f["normalisation"].attrs["json"])
        stage = stage or ("visible" if "visible" in f else "deposit")
        if stage not in f:
            stages = ", ".join(s for s in ("deposit", "visible") if s in f)
            raise ConfigError(f"{path}: has no {stage} templates (stages: {stages})")
        dets = list(f[stage]["detectors"])
        if kind == "m2_sum":
            g = f[stage]["m2_sum"]
            error = f[stage]["m2_sum_error"]["weights"][()]
            detector = "all"
        else:
            if kind not in KINDS:
                raise ConfigError(
                    f"template kind: {kind!r} is not one of {', '.join((*KINDS, 'm2_sum'))}"
                )
            if detector is None:
                if len(dets) != 1:
                    raise ConfigError(
                        f"{path}: holds detectors {', '.join(dets)}; name one (detector:)"
                    )
                detector = dets[0]
            if detector not in dets:
                raise ConfigError(
                    f"{path}: has no detector {detector!r}; detectors: {', '.join(dets)}"
                )
            g = f[stage]["detectors"][detector][kind]
            error = f[stage]["detectors"][detector][f"{kind}_error"]["weights"][()]
        return StoredTemplate(
            file=path,
            stage=stage,
            detector=detector,
            kind=kind,
            edges_kev=g["binning/axis_0/binedges"][()],
            rate=g["weights"][()],
            error=error,
            mass_kg=float(g.attrs["mass_kg"]),
            normalisation=norm,
        )


def template_hist(edges: list[np.ndarray], rate: np.ndarray, error: np.ndarray, unit: str):
    """A :class:`hist.Hist` of a template: energy axes in keV, ``Weight`` storage (value = rate,
    variance = error squared), ``label`` the rate's unit."""
    import hist

    axes = [
        hist.axis.Variable(e, name=f"energy{k if len(edges) > 1 else ''}", label="energy [keV]")
        for k, e in enumerate(edges)
    ]
    h = hist.Hist(*axes, storage=hist.storage.Weight(), label=unit)
    view = h.view()
    view.value = rate
    view.variance = np.asarray(error) ** 2
    return h


def read_hist(path: str | Path, name: str):
    """A template of a templates file as a :class:`hist.Hist` with its errors: ``name`` is the
    histogram's path (``deposit/detectors/crystal/all``, ``visible/m2_sum``, ...)."""
    path = Path(path)
    with open_h5(path, FORMAT, "templates", ConfigError) as f:
        if name not in f or f"{name}_error" not in f:
            raise ConfigError(f"{path}: has no template {name!r}")
        g = f[name]
        axes = g["binning"]
        edges = [axes[f"axis_{k}"]["binedges"][()] for k in range(len(axes))]
        return template_hist(
            edges, g["weights"][()], f[f"{name}_error"]["weights"][()], str(g.attrs["units"])
        )
