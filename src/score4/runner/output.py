"""Run results in HDF5: chunk files written atomically, merged into one file per run.

Layout of a results file (lengths in mm, energies in MeV, stated in ``units`` attributes)::

    /                  attrs: format="score4-results", format_version
    /run               attrs: config (JSON), seed, physics_mode, physics_lacks, versions, ...
    /events/event_id   (n,) int64
    /events/primary_energy  (n,) total primary kinetic energy of the event
    /events/atom       (n,) int64, per-atom histories only: the deposited atom of the event
    /events/edep/<volume>   (n,) energy deposited in that volume
    /events/track_length/<volume>  (n,) summed track length in that volume (if scored)
    /events/edep_alpha|edep_electron|edep_ion/<volume>  (n,) the deposit split by the class of
                       the particle that made it (output.split_by_particle, see sim/scoring.py)
    /primaries/{event, particle, energy, xloc, yloc, zloc, dirx, diry, dirz, <extra>...}

With per-atom histories (a chain with implantation) a chunk is a range of atoms
(attributes ``unit = "atom"``, ``first_event``: its first atom, ``n_units``: its atoms); its
events are numbered from 0 and :func:`merge_chunks` numbers them through the run. A chunk's
``counts`` attribute (JSON) holds the counts the run record adds up (intercepted ions,
implantation).

``/events`` (with its ``edep``/``track_length`` groups) and ``/primaries`` carry LH5 ``datatype``
attributes (``table{...}``, ``array<1>{real}``), so legend-lh5io reads them
(``lh5.read("events", file)``, ``lh5.read("primaries", file)``).

Every file is built in memory, written to ``<name>.partial`` and renamed into place only when
complete (:func:`score4.files.atomic_h5`), so an interrupted writer or a full disk never leaves
a truncated file under the final name, never touches a file that already exists, and never
crashes the process.
"""

from __future__ import annotations

import contextlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from score4.common.units import parse_quantity
from score4.errors import Score4Error
from score4.files import atomic_h5, open_h5
from score4.source.primaries import Primaries, atom_histories
from score4.source.vertex_file import read_primaries_table, write_primaries_table

FORMAT = "score4-results"
FORMAT_VERSION = 1
QUANTITY_UNITS = {
    "edep": "MeV",
    "track_length": "mm",
    # output.split_by_particle: edep by the class of the particle that deposited it
    "edep_alpha": "MeV",
    "edep_electron": "MeV",
    "edep_ion": "MeV",
    # targets[].activeness: each step's deposit weighted by the activeness at its position
    "active_edep": "MeV",
}
#: /stp/<volume> columns as remage writes its germanium steps: (name, dtype, units)
STEP_COLUMNS = (
    ("evtid", np.int32, None),
    ("particle", np.int32, None),
    ("edep", np.float64, "keV"),
    ("time", np.float64, "ns"),
    ("xloc", np.float64, "m"),
    ("yloc", np.float64, "m"),
    ("zloc", np.float64, "m"),
    ("dist_to_surf", np.float64, "m"),
)


@contextlib.contextmanager
def results_h5(path: Path):
    """A new results file (format attributes set), written by :func:`score4.files.atomic_h5`."""
    with atomic_h5(path) as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        yield f


def write_chunk(
    path: Path,
    first_event: int,
    volumes: list[str],
    scores: dict[str, np.ndarray],
    primaries: Primaries,
    fingerprint: str = "",
    columns: dict[str, np.ndarray] | None = None,
    counts: dict | None = None,
    steps: dict[str, np.ndarray] | None = None,
) -> None:
    """Write one finished chunk (events ``first_event ...``; atoms, for per-atom histories)
    atomically.

    ``scores`` maps a quantity ("edep", "track_length") to an (n_events, n_volumes) array;
    ``fingerprint`` identifies the configuration and seed, so a resume never mixes runs;
    ``columns``: more per-event energies (MeV), ``/events/<name>`` (e.g.
    ``untracked_gamma_energy`` in lite physics); ``counts``: numbers the run record adds up
    over the chunks (:func:`chunk_counts`); ``steps``: the chunk's steps
    (:meth:`score4.sim.simulation.Simulation.step_table`), written as ``/stp/<volume>``.
    """
    n = primaries.n_events
    atoms = atom_histories(primaries)
    offset = 0 if atoms else first_event  # atoms: events numbered by merge_chunks
    with results_h5(path) as f:
        f.attrs["first_event"] = first_event
        f.attrs["fingerprint"] = fingerprint
        f.attrs["counts"] = json.dumps(counts or {})
        ev = f.create_group("events")
        ev.attrs["quantities"] = json.dumps(list(scores))
        ev.create_dataset("event_id", data=offset + np.arange(n, dtype=np.int64))
        if atoms:
            f.attrs["unit"] = "atom"
            atom = primaries.extra["atom"][primaries.event_offsets()[:-1]]
            f.attrs["n_units"] = len(np.unique(atom))
            ev.create_dataset("atom", data=np.asarray(atom, np.int64))
        total = np.bincount(primaries.event, weights=primaries.energy, minlength=n)
        ev.create_dataset("primary_energy", data=total).attrs["units"] = "MeV"
        for name, values in (columns or {}).items():
            ev.create_dataset(name, data=np.asarray(values, dtype=float)).attrs["units"] = "MeV"
        for quantity, values in scores.items():
            g = ev.create_group(quantity)
            g.attrs["volumes"] = json.dumps(volumes)
            for k, name in enumerate(volumes):
                g.create_dataset(name, data=values[:, k]).attrs["units"] = QUANTITY_UNITS[quantity]
        _label_lh5(ev, volumes, list(scores))
        write_primaries_table(f.create_group("primaries"), primaries, offset)
        if steps is not None:
            tables = {}
            for k, name in enumerate(volumes):
                rows = steps["volume"] == k
                tables[name] = {
                    "evtid": offset + steps["event"][rows],
                    "particle": steps["particle"][rows],
                    "edep": steps["edep"][rows] * 1e3,  # MeV -> keV
                    "time": steps["time"][rows],
                    "xloc": steps["x"][rows] * 1e-3,  # mm -> m
                    "yloc": steps["y"][rows] * 1e-3,
                    "zloc": steps["z"][rows] * 1e-3,
                    "dist_to_surf": steps["dist"][rows] * 1e-3,
                }
            write_step_tables(f, volumes, tables)


def write_step_tables(f: h5py.File, volumes: list[str], tables: dict[str, dict]) -> None:
    """``/stp/<volume>``: flat LH5 tables of steps as remage writes them (``datatype``
    attributes ``struct{...}``, ``table{...}``, ``array<1>{real}``; units keV, ns, m)."""
    stp = f.create_group("stp")
    stp.attrs["datatype"] = "struct{" + ",".join(volumes) + "}"
    for name in volumes:
        g = stp.create_group(name)
        g.attrs["datatype"] = "table{" + ",".join(c for c, _, _ in STEP_COLUMNS) + "}"
        for column, dtype, unit in STEP_COLUMNS:
            d = g.create_dataset(column, data=np.asarray(tables[name][column], dtype=dtype))
            d.attrs["datatype"] = "array<1>{real}"
            if unit is not None:
                d.attrs["units"] = unit


def chunk_counts(paths: list[Path]) -> dict:
    """The ``counts`` of chunk files added up (nested dicts of numbers)."""
    total: dict = {}
    for path in paths:
        with h5py.File(path, "r") as f:
            _add_counts(total, json.loads(f.attrs.get("counts", "{}")))
    return total


def _add_counts(total: dict, part: dict) -> None:
    for key, value in part.items():
        if isinstance(value, dict):
            _add_counts(total.setdefault(key, {}), value)
        else:
            total[key] = total.get(key, 0) + value


def _event_columns(events: h5py.Group) -> list[str]:
    """The per-event arrays of ``/events`` (``event_id``, ``primary_energy`` and any more)."""
    return [k for k in events if isinstance(events[k], h5py.Dataset)]


def _label_lh5(events: h5py.Group, volumes: list[str], quantities: list[str]) -> None:
    """Give ``/events`` and its per-quantity groups the LH5 ``datatype`` attributes."""
    columns = _event_columns(events)
    for name in columns:
        events[name].attrs["datatype"] = "array<1>{real}"
    for quantity in quantities:
        for name in volumes:
            events[quantity][name].attrs["datatype"] = "array<1>{real}"
        events[quantity].attrs["datatype"] = "table{" + ",".join(volumes) + "}"
    events.attrs["datatype"] = "table{" + ",".join([*columns, *quantities]) + "}"


def merge_chunks(chunk_paths: list[Path], out: Path, run_record: dict) -> None:
    """Concatenate chunk files (in the given order) into the final results file."""
    parts = [h5py.File(p, "r") for p in chunk_paths]
    try:
        volumes = json.loads(parts[0]["events/edep"].attrs["volumes"])
        quantities = json.loads(parts[0]["events"].attrs["quantities"])
        with results_h5(out) as f:
            run = f.create_group("run")
            for key, value in run_record.items():
                # containers and None (HDF5 attributes hold neither) as JSON
                run.attrs[key] = (
                    json.dumps(value)
                    if isinstance(value, (dict, list, tuple)) or value is None
                    else value
                )
            ev = f.create_group("events")
            ev.attrs["quantities"] = json.dumps(quantities)
            # per-atom histories: each chunk's events are numbered from 0; number them on
            offsets = np.cumsum([0] + [len(p["events/event_id"]) for p in parts])
            renumber = any(p.attrs.get("unit") == "atom" for p in parts)
            # columns every chunk has (a chunk of an older version may lack a newer column)
            shared = set.intersection(*(set(_event_columns(p["events"])) for p in parts))
            for name in [c for c in _event_columns(parts[0]["events"]) if c in shared]:
                data = np.concatenate([p["events"][name][()] for p in parts])
                if renumber and name == "event_id":
                    data = np.arange(offsets[-1], dtype=np.int64)
                d = ev.create_dataset(name, data=data)
                if "units" in parts[0]["events"][name].attrs:
                    d.attrs["units"] = parts[0]["events"][name].attrs["units"]
            for quantity in quantities:
                g = ev.create_group(quantity)
                g.attrs["volumes"] = json.dumps(volumes)
                for name in volumes:
                    data = np.concatenate([p["events"][quantity][name][()] for p in parts])
                    g.create_dataset(name, data=data).attrs["units"] = QUANTITY_UNITS[quantity]
            _label_lh5(ev, volumes, quantities)
            if all("stp" in p for p in parts):
                tables = {}
                for name in volumes:
                    tables[name] = {
                        c: np.concatenate(
                            [
                                p["stp"][name][c][()] + (o if renumber and c == "evtid" else 0)
                                for p, o in zip(parts, offsets[:-1], strict=True)
                            ]
                        )
                        for c, _, _ in STEP_COLUMNS
                    }
                write_step_tables(f, volumes, tables)
            prim = f.create_group("primaries")
            prim.attrs.update(dict(parts[0]["primaries"].attrs))
            for key in parts[0]["primaries"]:
                src = [p["primaries"][key] for p in parts]
                values = [s[()] for s in src]
                if renumber and key == "event":
                    values = [v + o for v, o in zip(values, offsets[:-1], strict=True)]
                d = prim.create_dataset(key, data=np.concatenate(values))
                d.attrs.update(dict(src[0].attrs))
    finally:
        for p in parts:
            p.close()


@dataclass
class Results:
    """A results file in memory."""

    path: Path
    run: dict
    event_id: np.ndarray
    primary_energy: np.ndarray
    scores: dict[str, dict[str, np.ndarray]]  # quantity -> volume -> (n_events,)
    primaries: Primaries
    # more per-event columns of /events, e.g. untracked_gamma_energy (MeV) in lite physics
    columns: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_events(self) -> int:
        return len(self.event_id)

    @property
    def edep(self) -> dict[str, np.ndarray]:
        """Energy deposit (MeV) per volume."""
        return self.scores["edep"]

    @property
    def active(self) -> bool:
        """True when the run scored the active energy (``targets[].activeness``)."""
        return "active_edep" in self.scores

    @property
    def detected(self) -> dict[str, np.ndarray]:
        """The energy a detector sees (MeV) per volume: the active energy when the run has
        activeness (volumes without activeness: their whole deposit), else the deposit."""
        return self.scores["active_edep"] if self.active else self.scores["edep"]


def _decode_attr(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str) and value == "null":  # None, stored as JSON
        return None
    if isinstance(value, str) and value[:1] in "[{":
        with contextlib.suppress(json.JSONDecodeError):
            return json.loads(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


def read_results(path: str | Path) -> Results:
    """Load a results file written by :func:`merge_chunks`."""
    path = Path(path)
    with open_h5(path, FORMAT, "results") as f:
        if "run" not in f:
            raise Score4Error(
                f"results: {path} is not a finished score4 results file (no run record)"
            )
        volumes = json.loads(f["events/edep"].attrs["volumes"])
        quantities = json.loads(f["events"].attrs["quantities"])
        return Results(
            path=path,
            run={k: _decode_attr(v) for k, v in f["run"].attrs.items()},
            event_id=f["events/event_id"][()],
            primary_energy=f["events/primary_energy"][()],
            scores={q: {name: f["events"][q][name][()] for name in volumes} for q in quantities},
            primaries=read_primaries_table(f["primaries"]),
            columns={
                k: f["events"][k][()]
                for k in _event_columns(f["events"])
                if k not in ("event_id", "primary_energy")
            },
        )


def multiplicity(results: Results, threshold: float) -> dict:
    """Events by how many volumes have a deposit above ``threshold`` (MeV), and per volume the
    events above it (alone and in all)."""
    names = list(results.detected)
    if not names:
        return {"threshold_MeV": threshold, "counts": {}, "volumes": {}}
    hits = np.column_stack([results.detected[n] > threshold for n in names])
    m = hits.sum(axis=1)
    counts = np.bincount(m, minlength=len(names) + 1)
    return {
        "threshold_MeV": threshold,
        "counts": {int(k): int(c) for k, c in enumerate(counts)},
        "volumes": {
            n: {"above": int(hits[:, k].sum()), "alone": int((hits[:, k] & (m == 1)).sum())}
            for k, n in enumerate(names)
        },
    }


def summarize(
    results: Results,
    bins: int | None = None,
    emax: float | None = None,
    threshold: float | None = None,
) -> dict:
    """The run summary: counts, mean deposits and a histogram per volume (MeV); with
    ``threshold`` (MeV) also the multiplicity (:func:`multiplicity`) and, per volume, events
    above it per simulated event and per kg (mass from the run record's ``volumes``)."""
    hist_cfg = results.run.get("config", {}).get("output", {}).get("histogram", {})
    bins = bins or hist_cfg.get("bins") or 100
    stored_max = hist_cfg.get("max")  # stored with its unit ("6.0 MeV")
    stored_max = parse_quantity(stored_max, "energy") if stored_max is not None else None
    emax = emax or stored_max or float(results.primary_energy.max(initial=0.0)) or 1.0
    from score4.common import limits

    limits.check_bins(int(bins), "--bins", n_1d=max(1, len(results.edep)))
    edges = np.linspace(0.0, emax, bins + 1)
    volumes = []
    for name, e in results.detected.items():
        # Sums of step deposits can exceed the emitted energy by rounding (1e-15 MeV): such
        # values belong in the top bin; anything really above the range is counted as overflow.
        at_top = (e > emax) & (e <= emax * (1 + 1e-9))
        counts, _ = np.histogram(np.where(at_top, emax, e), bins=edges)
        volumes.append(
            {
                "name": name,
                "mean_edep_MeV": float(e.mean()) if len(e) else 0.0,
                "n_nonzero": int(np.count_nonzero(e)),
                "histogram": {
                    # 12 digits: 0.05, not linspace's 0.049999999999999996
                    "edges_MeV": [float(f"{x:.12g}") for x in edges],
                    "counts": counts.tolist(),
                    "overflow": int(np.count_nonzero(e > emax * (1 + 1e-9))),
                },
            }
        )
    records = {v.get("name"): v for v in results.run.get("volumes") or []}
    for v in volumes:
        record = records.get(v["name"])
        if record:
            v["material"] = record.get("material")
            v["mass_kg"] = record.get("mass_kg")
    summary = {
        "file": str(results.path),
        "n_events": results.n_events,
        "physics_mode": results.run.get("physics_mode"),
        "seed": results.run.get("seed"),
        # the energy the histograms, means and rates are of
        "energy": "active_edep" if results.active else "edep",
        "volumes": volumes,
    }
    if threshold is not None:
        multi = multiplicity(results, threshold)
        n = max(results.n_events, 1)
        for v in volumes:
            above = multi["volumes"][v["name"]]
            v["above_threshold"] = above["above"]
            v["alone_above_threshold"] = above["alone"]
            v["rate_per_event"] = above["above"] / n
            mass = v.get("mass_kg")
            v["rate_per_event_per_kg"] = above["above"] / n / mass if mass else None
        summary["multiplicity"] = {"threshold_MeV": threshold, "events": multi["counts"]}
    return summary
