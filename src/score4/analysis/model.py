"""A background model: templates times activities, summed; fitted to a measured spectrum.

A model file (YAML, validated like the run configuration) names one detector spectrum and the
components that feed it, each a templates file (``score4 template``) with an activity::

    detector: bottom            # a detector of the templates files (default: their only one)
    kind: all                   # all | m1 | m2 | m2_sum
    livetime: 30 d              # converts rates to counts
    range: [4 MeV, 6 MeV]       # fit window (default: the whole template range)
    roi: [5.2 MeV, 5.5 MeV]     # drawn and summed (optional)
    components:
      - {name: Po-210 top face, template: top.h5, activity: 2 mBq/cm2}
      - {name: Po-210 bottom face, template: bottom.h5, activity: 1 mBq/cm2, fit: false}
    data: {file: measured.csv}  # or {file: spectrum.root, histogram: h, unit: keV}

A component's template was made for a reference activity ``A_ref``; its contribution for an
activity ``A`` of the same kind (per area, per mass, ...) is ``A / A_ref`` times the template.
The expected counts in bin ``i`` are ``mu_i = sum_c (A_c / A_ref,c) R_c,i dE_i m T`` (``R`` in
counts/(keV kg day), ``dE`` keV, ``m`` the detector mass, ``T`` the live time in days).

The fit (:func:`fit_model`) maximises the binned Poisson likelihood of the data in the fit
window over the activities of the components with ``fit: true`` (default), with iminuit's MIGRAD
and HESSE (errors at delta(-ln L) = 1/2, correlations from the covariance); activities are
bounded below by 0.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, ValidationError, field_validator, model_validator

from score4.common.schema import ConfigPath, StrictModel, describe_validation_error
from score4.common.units import (
    ACTIVITY_KINDS,
    DIMENSIONS,
    ENERGY,
    parse_activity,
    parse_quantity,
    split_quantity,
)
from score4.common.yamlfile import load_yaml
from score4.errors import ConfigError

from .templates import SECONDS_PER_DAY, StoredTemplate, read_template

#: Bin edges of data and templates closer than this (keV) are the same edge.
EDGE_TOLERANCE = 1e-6


def _activity_text(value: object) -> str:
    parse_activity(value, "activity")  # fails with a one-line reason
    return str(value)


class ComponentConfig(StrictModel):
    """A source of the model: its templates file (several files: runs of the same source, merged
    weighted by their simulated decays) and its activity."""

    name: str = Field(min_length=1)
    template: ConfigPath | list[ConfigPath]
    activity: str  # "2 mBq/cm2": the model's value, the fit's starting value
    fit: bool = True

    _check_activity = field_validator("activity", mode="before")(_activity_text)


class DataConfig(StrictModel):
    """A measured spectrum: CSV (``bin_low_keV,bin_high_keV,counts``, or ``_MeV``) or a ROOT TH1."""

    file: ConfigPath
    histogram: str | None = None  # ROOT files: the histogram's name
    unit: str | None = (
        None  # ROOT files: energy unit of the axis (default: from its title, else keV)
    )

    @model_validator(mode="after")
    def _root_keys(self) -> DataConfig:
        is_root = self.file.suffix.lower() == ".root"
        if is_root and self.histogram is None:
            raise ValueError("a ROOT file needs histogram: <name of a TH1 in it>")
        if not is_root and (self.histogram is not None or self.unit is not None):
            raise ValueError(
                "histogram and unit apply to ROOT files only (a CSV names its unit in its header)"
            )
        if self.unit is not None and self.unit not in ENERGY:
            raise ValueError(f"unit: {self.unit!r} is not an energy unit ({', '.join(ENERGY)})")
        return self


class ModelConfig(StrictModel):
    """A model file (see the module notes)."""

    detector: str | None = None
    kind: str = Field("all", pattern="^(all|m1|m2|m2_sum)$")
    stage: str | None = Field(None, pattern="^(deposit|visible)$")
    livetime: str
    range: tuple[float, float] | None = None  # MeV after validation ("4 MeV" as written)
    roi: tuple[float, float] | None = None
    components: list[ComponentConfig] = Field(min_length=1)
    data: DataConfig | None = None

    @field_validator("livetime", mode="before")
    @classmethod
    def _livetime(cls, value: object) -> str:
        if not parse_quantity(value, "time", "livetime") > 0:
            raise ValueError(f"must be greater than 0, got {value!r}")
        return str(value)

    @field_validator("range", "roi", mode="before")
    @classmethod
    def _window(cls, value: object) -> object:
        if value is None:
            return None
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            raise ValueError(
                f"give two energies [low, high], e.g. ['4 MeV', '6 MeV'], got {value!r}"
            )
        lo, hi = (parse_quantity(v, "energy") for v in value)
        if not 0 <= lo < hi:
            raise ValueError(f"need 0 <= low < high, got {list(value)}")
        return lo, hi

    @model_validator(mode="after")
    def _names(self) -> ModelConfig:
        names = [c.name for c in self.components]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"components: names must be unique, repeated: {', '.join(dupes)}")
        return self

    @property
    def livetime_days(self) -> float:
        return parse_quantity(self.livetime, "time") * 1e-9 / SECONDS_PER_DAY


def load_model(path: str | Path) -> ModelConfig:
    """Read and validate a model file."""
    path = Path(path)
    data = load_yaml(path, "model")
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a model file is a mapping of keys (components, livetime, ...)")
    try:
        return ModelConfig.model_validate(data, context={"base_dir": path.parent})
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, str(path))) from None


# --- the model ----------------------------------------------------------------------------------


@dataclass
class Component:
    """A component: its template, the model activity and how it scales the template."""

    name: str
    template: StoredTemplate
    activity_text: str  # as written in the model
    unit: str  # the unit the user wrote ("mBq/cm2")
    unit_factor: float  # that unit in internal units (Bq/mm2, Bq/kg, Bq/mm3, Bq)
    scale: float  # model activity / template activity
    fit: bool

    @property
    def activity(self) -> float:
        """The model activity in the user's unit."""
        return self.scale * self.reference / self.unit_factor

    @property
    def reference(self) -> float:
        """The template's activity, internal units."""
        return float(self.template.activity["value"])


@dataclass
class Model:
    """Components of one detector spectrum on common bins."""

    config: ModelConfig
    components: list[Component]
    edges_kev: np.ndarray
    mass_kg: float
    livetime_days: float

    def per_unit_scale(self) -> np.ndarray:
        """(n_components, n_bins) expected counts per bin for scale 1 (the template activity)."""
        width = np.diff(self.edges_kev)
        factor = width * self.mass_kg * self.livetime_days
        return np.array([c.template.rate * factor for c in self.components])

    def expected(self, scales: np.ndarray | None = None) -> np.ndarray:
        """Expected counts per bin for ``scales`` (default: the model's activities)."""
        s = np.array([c.scale for c in self.components]) if scales is None else np.asarray(scales)
        return s @ self.per_unit_scale()

    def rates(self) -> list[np.ndarray]:
        """Each component's rate at the model activity, counts/(keV kg day)."""
        return [c.scale * c.template.rate for c in self.components]


def merge_runs(templates: list[StoredTemplate], where: str) -> StoredTemplate:
    """Templates of several runs of one source as one: each scaled to the first one's activity,
    averaged with weights proportional to their simulated decays (errors combined likewise)."""
    first = templates[0]
    for t in templates[1:]:
        same_bins = len(t.edges_kev) == len(first.edges_kev) and np.allclose(
            t.edges_kev, first.edges_kev, rtol=0, atol=EDGE_TOLERANCE
        )
        if not same_bins or t.activity["kind"] != first.activity["kind"]:
            raise ConfigError(
                f"{where}: {t.file} and {first.file} cannot be merged: they need the same bins "
                "and activities of the same kind"
            )
        if not np.isclose(t.mass_kg, first.mass_kg, rtol=1e-9):
            raise ConfigError(f"{where}: {t.file} and {first.file} are not of the same detector")
    decays = np.array([float(t.normalisation["simulated_decays"]) for t in templates])
    weights = decays / decays.sum()
    ratio = [float(first.activity["value"]) / float(t.activity["value"]) for t in templates]
    rate = sum(w * r * t.rate for w, r, t in zip(weights, ratio, templates, strict=True))
    error = np.sqrt(
        sum((w * r * t.error) ** 2 for w, r, t in zip(weights, ratio, templates, strict=True))
    )
    norm = dict(first.normalisation, simulated_decays=float(decays.sum()))
    return replace(first, rate=np.asarray(rate), error=np.asarray(error), normalisation=norm)


def _component(cfg: ComponentConfig, model: ModelConfig) -> Component:
    files = cfg.template if isinstance(cfg.template, list) else [cfg.template]
    if not files:
        raise ConfigError(f"components.{cfg.name}.template: give at least one templates file")
    where = f"components.{cfg.name}.template"
    t = merge_runs(
        [read_template(f, model.detector, model.kind, model.stage) for f in files], where
    )
    kind, value = parse_activity(cfg.activity, f"components.{cfg.name}.activity")
    ref_kind = t.activity["kind"]
    if kind != ref_kind:
        raise ConfigError(
            f"components.{cfg.name}.activity: {cfg.activity!r} is per {kind}, but the template "
            f"{t.file} was made for an activity per {ref_kind} ({t.activity['text']})"
        )
    dimension = ACTIVITY_KINDS[kind]
    written = split_quantity(cfg.activity)
    assert written is not None  # parse_activity accepted it
    unit = written[1]
    return Component(
        name=cfg.name,
        template=t,
        activity_text=cfg.activity,
        unit=unit,
        unit_factor=DIMENSIONS[dimension][unit],
        scale=value / float(t.activity["value"]),
        fit=cfg.fit,
    )


def build_model(config: ModelConfig) -> Model:
    """Read every component's template; check they share bins and the detector mass."""
    components = [_component(c, config) for c in config.components]
    first = components[0].template
    for c in components[1:]:
        t = c.template
        if len(t.edges_kev) != len(first.edges_kev) or not np.allclose(
            t.edges_kev, first.edges_kev, rtol=0, atol=EDGE_TOLERANCE
        ):
            raise ConfigError(
                f"components.{c.name}: the template {t.file} has other bins "
                f"({_bins_text(t.edges_kev)}) than {first.file} ({_bins_text(first.edges_kev)}); "
                "make all templates with the same --bins, --emin, --emax"
            )
        if not np.isclose(t.mass_kg, first.mass_kg, rtol=1e-9):
            raise ConfigError(
                f"components.{c.name}: the detector {t.detector} of {t.file} weighs "
                f"{t.mass_kg:.6g} kg, but {first.mass_kg:.6g} kg in {first.file}: the templates "
                "are not of the same detector"
            )
    return Model(config, components, first.edges_kev, first.mass_kg, config.livetime_days)


def _bins_text(edges: np.ndarray) -> str:
    return f"{len(edges) - 1} bins from {edges[0]:g} to {edges[-1]:g} keV"


# --- data ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Spectrum:
    """A measured (or pseudo) spectrum: counts per bin on edges in keV."""

    edges_kev: np.ndarray
    counts: np.ndarray
    source: str


def read_csv_spectrum(path: str | Path) -> Spectrum:
    """Rows ``bin_low_<unit>,bin_high_<unit>,counts`` (unit keV or MeV); ``#`` lines skipped."""
    path = Path(path)
    try:
        lines = [
            ln
            for ln in path.read_text().splitlines()
            if ln.strip() and not ln.lstrip().startswith("#")
        ]
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"data: cannot read {path} ({err})") from None
    rows = list(csv.DictReader(io.StringIO("\n".join(lines))))
    header = list(rows[0]) if rows else []
    unit = next(
        (u for u in ("keV", "MeV") if f"bin_low_{u}" in header and f"bin_high_{u}" in header), None
    )
    if unit is None or "counts" not in header:
        raise ConfigError(
            f"data: {path} needs the columns bin_low_keV, bin_high_keV, counts (or bin_low_MeV, "
            f"bin_high_MeV); its header is {','.join(header) or 'empty'}"
        )
    try:
        lo = np.array([float(r[f"bin_low_{unit}"]) for r in rows])
        hi = np.array([float(r[f"bin_high_{unit}"]) for r in rows])
        counts = np.array([float(r["counts"]) for r in rows])
    except (TypeError, ValueError) as err:
        raise ConfigError(f"data: {path}: a row is not numbers ({err})") from None
    scale = ENERGY[unit] / ENERGY["keV"]
    if len(lo) > 1 and not np.allclose(
        hi[:-1], lo[1:], rtol=0, atol=1e-9 * max(1.0, abs(hi).max())
    ):
        raise ConfigError(
            f"data: {path}: bins must be contiguous (each bin_low equal to the previous bin_high)"
        )
    return _spectrum(np.append(lo, hi[-1]) * scale, counts, str(path))


def _spectrum(edges: np.ndarray, counts: np.ndarray, source: str) -> Spectrum:
    if len(counts) == 0:
        raise ConfigError(f"data: {source} holds no bins")
    if np.any(np.diff(edges) <= 0):
        raise ConfigError(f"data: {source}: bin edges must increase")
    if np.any(counts < 0) or not np.all(np.isfinite(counts)):
        raise ConfigError(f"data: {source}: counts must be finite and >= 0")
    return Spectrum(edges, counts, source)


def read_root_spectrum(path: str | Path, histogram: str, unit: str | None = None) -> Spectrum:
    """A ROOT TH1 (uproot); energy unit: ``unit``, else the axis title's (``[MeV]``), else keV."""
    import uproot

    try:
        with uproot.open(path) as f:
            if histogram not in f:
                names = ", ".join(k.split(";")[0] for k in f if f[k].classname.startswith("TH1"))
                raise ConfigError(
                    f"data: {path} has no histogram {histogram!r}; TH1 histograms: "
                    f"{names or 'none'}"
                )
            h = f[histogram]
            counts, edges = h.to_numpy()
            title = str(h.member("fXaxis").member("fTitle"))
    except (OSError, ValueError) as err:
        raise ConfigError(f"data: cannot read {path} as a ROOT file ({err})") from None
    if unit is None:
        unit = next((u for u in ("MeV", "keV") if f"[{u}]" in title), "keV")
    return _spectrum(
        np.asarray(edges, float) * ENERGY[unit] / ENERGY["keV"],
        np.asarray(counts, float),
        f"{path}:{histogram}",
    )


def read_spectrum(cfg: DataConfig) -> Spectrum:
    if cfg.file.suffix.lower() == ".root":
        assert cfg.histogram is not None  # the model requires it
        return read_root_spectrum(cfg.file, cfg.histogram, cfg.unit)
    return read_csv_spectrum(cfg.file)


def match_bins(model_edges: np.ndarray, data: Spectrum) -> np.ndarray:
    """For each model bin, the data bin it falls in (-1 outside the data); ConfigError when a data
    edge is not a model edge (the templates cannot be summed into the data's bins)."""
    index = np.searchsorted(model_edges, data.edges_kev)
    index = np.clip(index, 0, len(model_edges) - 1)
    near = np.minimum(
        np.abs(model_edges[index] - data.edges_kev),
        np.abs(model_edges[np.maximum(index - 1, 0)] - data.edges_kev),
    )
    bad = near > EDGE_TOLERANCE * np.maximum(1.0, np.abs(data.edges_kev))
    if bad.any():
        first = float(data.edges_kev[np.argmax(bad)])
        raise ConfigError(
            f"data: the bins of {data.source} ({_bins_text(data.edges_kev)}) cannot be matched "
            f"with the templates' ({_bins_text(model_edges)}): its edge {first:g} keV is not a "
            "template edge; make the templates with --bins/--emin/--emax so that every data edge "
            "is a template edge"
        )
    which = np.full(len(model_edges) - 1, -1)
    data_index = np.searchsorted(data.edges_kev, (model_edges[:-1] + model_edges[1:]) / 2) - 1
    inside = (data_index >= 0) & (data_index < len(data.counts))
    which[inside] = data_index[inside]
    return which


# --- fit ----------------------------------------------------------------------------------------


@dataclass
class FitResult:
    """Activities (user units) with errors and correlations, and the fit's quality."""

    names: list[str]
    activity: dict[str, float]
    error: dict[str, float]
    units: dict[str, str]
    fitted: list[str]
    correlation: np.ndarray  # among fitted components, in ``fitted`` order
    scales: np.ndarray
    valid: bool
    deviance: float
    n_bins: int
    expected: np.ndarray  # on the data bins
    data: np.ndarray
    edges_kev: np.ndarray
    components: np.ndarray  # (n_components, n_data_bins) at the fitted activities

    def to_dict(self) -> dict[str, Any]:
        return {
            "valid": self.valid,
            "activities": {
                n: {
                    "value": self.activity[n],
                    "error": self.error.get(n),
                    "unit": self.units[n],
                    "fitted": n in self.fitted,
                }
                for n in self.names
            },
            "correlation": {"order": self.fitted, "matrix": self.correlation.tolist()},
            "deviance": self.deviance,
            "bins": self.n_bins,
            "dof": self.n_bins - len(self.fitted),
        }


def data_bins(model: Model, data: Spectrum) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(per-unit-scale expected counts on the data bins in the fit window, data counts, edges)."""
    which = match_bins(model.edges_kev, data)
    per_unit = model.per_unit_scale()
    n_data = len(data.counts)
    summed = np.zeros((len(model.components), n_data))
    for k in range(n_data):
        summed[:, k] = per_unit[:, which == k].sum(axis=1)
    covered = np.array([(which == k).any() for k in range(n_data)])
    keep = covered
    if model.config.range is not None:
        lo, hi = (v * 1e3 for v in model.config.range)  # MeV -> keV
        keep = (
            keep
            & (data.edges_kev[:-1] >= lo - EDGE_TOLERANCE)
            & (data.edges_kev[1:] <= hi + EDGE_TOLERANCE)
        )
    if not keep.any():
        raise ConfigError(
            f"data: no bin of {data.source} lies inside the templates' range and the fit range"
        )
    edges = data.edges_kev
    # keep contiguous runs only for the plot: edges of kept bins
    kept_edges = np.append(edges[:-1][keep], edges[1:][keep][-1])
    return summed[:, keep], data.counts[keep], kept_edges


def poisson_nll(mu: np.ndarray, n: np.ndarray) -> float:
    """-ln L of Poisson counts ``n`` for expectations ``mu`` (constant terms dropped)."""
    mu = np.maximum(mu, 1e-300)
    return float(np.sum(mu - n * np.log(mu)))


def _check_fittable(
    model: Model, per_unit: np.ndarray, counts: np.ndarray, edges: np.ndarray
) -> None:
    """Refuse a fit no activity can make: a fitted component whose template is zero in every
    bin of the fit window (its activity changes nothing), or data counts in a bin where every
    template is zero (no activity explains them; the likelihood is 0)."""
    detector = model.components[0].template.detector
    for k, c in enumerate(model.components):
        if c.fit and not np.any(per_unit[k] > 0):
            raise ConfigError(
                f"components.{k} ({c.name}): its template is zero in every bin of the fit range "
                f"(none of its events deposits energy in {detector} there), so the data cannot "
                "tell its activity; give it fit: false or leave it out"
            )
    empty = (per_unit.sum(axis=0) <= 0) & (counts > 0)
    if empty.any():
        k = int(np.argmax(empty))
        raise ConfigError(
            f"data: the bin {edges[k]:.6g}-{edges[k + 1]:.6g} keV holds {counts[k]:.6g} counts "
            f"where every component's template is zero ({int(empty.sum())} such bin(s)): no "
            "activity explains them; add the component that makes them or narrow range:"
        )


def fit_model(model: Model, data: Spectrum) -> FitResult:
    """Fit the activities of the ``fit: true`` components to ``data`` (see the module notes)."""
    from iminuit import Minuit

    per_unit, counts, edges = data_bins(model, data)
    start = np.array([c.scale for c in model.components])
    names = [c.name for c in model.components]
    fitted = [c.name for c in model.components if c.fit]
    if not fitted:
        raise ConfigError("components: no component has fit: true; nothing to fit")
    _check_fittable(model, per_unit, counts, edges)

    def nll(*scales: float) -> float:
        return poisson_nll(np.asarray(scales) @ per_unit, counts)

    m = Minuit(nll, *np.where(start > 0, start, 1.0), name=names)
    m.errordef = Minuit.LIKELIHOOD
    for c in model.components:
        m.limits[c.name] = (0.0, None)
        m.fixed[c.name] = not c.fit
    m.migrad()
    m.hesse()
    scales = np.array(m.values)
    factors = {c.name: c.reference / c.unit_factor for c in model.components}
    idx = [names.index(n) for n in fitted]
    if m.covariance is None:  # HESSE failed: no errors, no correlations
        cov = np.full((len(idx), len(idx)), np.nan)
    else:
        cov = np.array(m.covariance)[np.ix_(idx, idx)]
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd) if np.all(sd > 0) else np.eye(len(idx))
    mu = scales @ per_unit
    with np.errstate(divide="ignore", invalid="ignore"):
        term = np.where(counts > 0, counts * np.log(counts / np.maximum(mu, 1e-300)), 0.0)
    deviance = float(2 * np.sum(mu - counts + term))
    return FitResult(
        names=names,
        activity={n: float(scales[i] * factors[n]) for i, n in enumerate(names)},
        error={n: float(m.errors[n] * factors[n]) for n in fitted},
        units={c.name: c.unit for c in model.components},
        fitted=fitted,
        correlation=corr,
        scales=scales,
        valid=bool(m.valid),
        deviance=deviance,
        n_bins=len(counts),
        expected=mu,
        data=counts,
        edges_kev=edges,
        components=scales[:, None] * per_unit,
    )


def pseudo_data(model: Model, seed: int) -> Spectrum:
    """Poisson counts drawn from the model at its activities (seeded), on the template bins."""
    rng = np.random.default_rng(seed)
    return Spectrum(
        model.edges_kev, rng.poisson(model.expected()).astype(float), f"pseudo-data seed {seed}"
    )


def write_csv_spectrum(spectrum: Spectrum, path: str | Path, header: str = "") -> Path:
    """Write a spectrum as ``bin_low_keV,bin_high_keV,counts`` (atomically)."""
    from score4.files import atomic_output

    lines = [f"# {line}" for line in header.splitlines() if line]
    lines.append("bin_low_keV,bin_high_keV,counts")
    e = [float(x) for x in spectrum.edges_kev]
    lines += [
        f"{e[k]!r},{e[k + 1]!r},{int(c) if float(c).is_integer() else c!r}"
        for k, c in enumerate(spectrum.counts.tolist())
    ]
    with atomic_output(Path(path)) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return Path(path)


def model_summary(model: Model) -> dict[str, Any]:
    """Predicted rates and counts per component (whole range and ROI)."""
    width = np.diff(model.edges_kev)
    out: dict[str, Any] = {
        "detector": model.components[0].template.detector,
        "kind": model.config.kind,
        "mass_kg": model.mass_kg,
        "livetime_days": model.livetime_days,
        "components": {},
    }
    roi = None if model.config.roi is None else tuple(v * 1e3 for v in model.config.roi)
    in_roi = None
    if roi is not None:
        centres = (model.edges_kev[:-1] + model.edges_kev[1:]) / 2
        in_roi = (centres >= roi[0]) & (centres < roi[1])
        if not in_roi.any():
            raise ConfigError(
                f"roi: {roi[0]:.6g} to {roi[1]:.6g} keV holds no bin centre of the templates "
                f"({model.edges_kev[0]:.6g} to {model.edges_kev[-1]:.6g} keV in "
                f"{len(model.edges_kev) - 1} bins)"
            )
    total_counts = 0.0
    for c, rate in zip(model.components, model.rates(), strict=True):
        counts = float((rate * width).sum() * model.mass_kg * model.livetime_days)
        total_counts += counts
        entry: dict[str, Any] = {
            "activity": c.activity,
            "unit": c.unit,
            "template": str(c.template.file),
            "counts_per_kg_day": float((rate * width).sum()),
            "expected_counts": counts,
        }
        if in_roi is not None:
            entry["roi_counts_per_keV_kg_day"] = float(
                (rate * width)[in_roi].sum() / width[in_roi].sum()
            )
        out["components"][c.name] = entry
    out["expected_counts"] = total_counts
    if in_roi is not None:
        out["roi_keV"] = [
            float(model.edges_kev[:-1][in_roi][0]),
            float(model.edges_kev[1:][in_roi][-1]),
        ]
    return out
