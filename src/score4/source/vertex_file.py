"""Primaries as an HDF5 table: in results files and in vertex files (``score4 vertices``).

One row per primary particle; the columns of a table group are

``event`` (int), ``particle`` (ASCII), ``energy`` (MeV), ``xloc``/``yloc``/``zloc`` (mm),
``dirx``/``diry``/``dirz`` (unit vector), and the extras the source adds: ``depth`` (mm),
``facet`` (triangle index in its patch variant), ``patch`` (flat cell index ``i * ny + j`` on a
tiled face, -1 on a flat one), ``face`` (sources on several faces of a volume: index into the
``faces`` list of the file's ``source`` attribute). A bulk source has none of these extras.

Every column carries a ``units`` attribute where it has a unit, and LH5 ``datatype``
attributes (``table{...}`` on the group, ``array<1>{real}`` on columns, ``array<1>{string}`` on
``particle``), the LEGEND convention, so legend-lh5io reads the tables (``lh5.read("vertices",
file)``; tested). The column order is fixed: the columns above, then the extras sorted by name.
LH5 strings are fixed-width byte strings: ``lh5`` 0.3.0 returns them as ``bytes`` (as it does
for files it writes itself); :func:`read_primaries_table` decodes them to ``str``.

A vertex file holds the table as ``/vertices`` and, as attributes of the root, the format
name, the configuration (JSON with units) and the seed it was drawn with. It also holds
``/vtx`` (``struct{pos,kin}``), the two tables of remage's ``FromFile`` inputs (``lh5.read("vtx",
file)`` is tested; remage itself is not installable here):

* ``/vtx/pos`` (``table{xloc,yloc,zloc}``): one row per event with ``xloc/yloc/zloc`` (float64,
  mm), the layout revertex writes and remage's ``FromFile`` vertex confinement reads;
* ``/vtx/kin`` (``table{ekin,g4_pid,px,py,pz,time,n_part}``): one row per primary, the layout
  remage's ``FromFile`` generator reads: ``ekin`` (float64, MeV), ``g4_pid`` (int32, the PDG
  code; ions ``100ZZZAAA0``), ``px/py/pz`` (float64, the unit direction), ``time`` (float64, ns
  after the event's first decay), ``n_part`` (int32: the event's number of rows on its first row,
  0 on the others). Written when every particle has a PDG code (:func:`pdg_codes`).
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from score4.inputs import limits
from score4.inputs.units import DIMENSIONS

from ..elements import split_ion_name
from ..errors import ConfigError, brief
from ..files import atomic_h5, open_h5
from .primaries import Primaries

FORMAT = "score4-vertices"
FORMAT_VERSION = 1
UNITS = {"energy": "MeV", "xloc": "mm", "yloc": "mm", "zloc": "mm", "depth": "mm", "time": "s"}
_FIXED = ("event", "particle", "energy", "xloc", "yloc", "zloc", "dirx", "diry", "dirz")


def write_primaries_table(group: h5py.Group, p: Primaries, event_offset: int = 0) -> None:
    """Write ``p`` as columns of ``group`` (events numbered from ``event_offset``)."""
    columns = {
        "event": p.event + event_offset,
        "particle": np.char.encode(p.particle.astype(str), "ascii"),
        "energy": p.energy,
        **{f"{a}loc": p.position[:, k] for k, a in enumerate("xyz")},
        **{f"dir{a}": p.direction[:, k] for k, a in enumerate("xyz")},
        **{k: p.extra[k] for k in sorted(p.extra)},
    }
    for name, data in columns.items():
        d = group.create_dataset(name, data=data)
        d.attrs["datatype"] = "array<1>{string}" if name == "particle" else "array<1>{real}"
        if name in UNITS:
            d.attrs["units"] = UNITS[name]
    group.attrs["datatype"] = "table{" + ",".join(columns) + "}"


_DIMENSION = {"energy": "energy", "xloc": "length", "yloc": "length", "zloc": "length"}
_DIMENSION["depth"] = "length"
#: Columns where NaN means something: ``depth`` of a decay that an alpha recoil moved out of
#: its deposit's volume (recoil implantation, :mod:`score4.sim.implantation`).
_MAY_BE_NAN = ("depth",)


def _column(group: h5py.Group, name: str, label: str) -> np.ndarray:
    """A column in internal units (its ``units`` attribute honoured), checked finite."""
    d = group[name]
    values = d[()]
    unit = d.attrs.get("units")
    if isinstance(unit, bytes):
        unit = unit.decode("ascii", "replace")
    dimension = _DIMENSION.get(name)
    if dimension is not None and unit is not None:
        factors = DIMENSIONS[dimension]
        if unit not in factors:
            raise ConfigError(
                f"{label}: column {name} has units {brief(unit)}; score4 reads {dimension}s in "
                f"{', '.join(factors)}"
            )
        values = values * factors[unit] if factors[unit] != 1.0 else values
    if name in _MAY_BE_NAN:  # NaN is a stated value there; infinities are not
        limits.check_finite(np.where(np.isnan(values), 0.0, values), f"{label}: column {name}")
    elif values.dtype.kind in "fc":
        limits.check_finite(values, f"{label}: column {name}")
    return values


def read_primaries_table(group: h5py.Group, label: str = "primaries") -> Primaries:
    """Read a table written by :func:`write_primaries_table` (or by another program in its layout).

    Lengths and energies are converted from the unit their ``units`` attribute names (mm, m, um,
    keV, ...; an unknown unit is refused); every number must be finite, every column as long as
    ``event``. ``label`` starts the error messages.
    """
    columns = {k: _column(group, k, label) for k in group if isinstance(group[k], h5py.Dataset)}
    for name in _FIXED:
        if name not in columns:
            raise KeyError(name)
    rows = len(columns["event"])
    uneven = {k: len(v) for k, v in columns.items() if len(v) != rows}
    if uneven:
        k, n = next(iter(uneven.items()))
        raise ConfigError(
            f"{label}: column {k} has {n} rows but event has {rows}; all columns must be "
            "equally long"
        )
    try:
        return Primaries(
            event=columns["event"],
            particle=np.char.decode(columns["particle"], "ascii"),
            energy=columns["energy"],
            position=np.column_stack([columns[f"{a}loc"] for a in "xyz"]),
            direction=np.column_stack([columns[f"dir{a}"] for a in "xyz"]),
            extra={k: v for k, v in columns.items() if k not in _FIXED},
        )
    except (ValueError, TypeError, UnicodeDecodeError) as err:
        if isinstance(err, ConfigError):
            raise
        raise ConfigError(f"{label}: the table cannot be read ({brief(str(err), 120)})") from None


#: PDG codes of the Geant4 particle names score4's sources use (ions: :func:`pdg_codes`).
PDG = {
    "e-": 11,
    "e+": -11,
    "nu_e": 12,
    "anti_nu_e": -12,
    "mu-": 13,
    "mu+": -13,
    "gamma": 22,
    "pi+": 211,
    "pi-": -211,
    "neutron": 2112,
    "proton": 2212,
    "deuteron": 1000010020,
    "triton": 1000010030,
    "He3": 1000020030,
    "alpha": 1000020040,
}


def pdg_codes(names: np.ndarray) -> np.ndarray | None:
    """PDG codes of Geant4 particle names (ions such as ``Pb206``: ``1000000000 + 10000 Z + 10 A``,
    ground state); None if a name has none (``geantino``: Geant4 gives it code 0, which no
    reader can look up)."""
    from ..ions.species import Z_OF

    names = np.asarray(names).astype(str)
    unique, inverse = np.unique(names, return_inverse=True)
    codes = np.zeros(len(unique), np.int64)
    for k, name in enumerate(unique):
        if name in PDG:
            codes[k] = PDG[name]
            continue
        ion = split_ion_name(name)
        if ion is None or ion[0] not in Z_OF:
            return None
        z, a = Z_OF[ion[0]], ion[1]
        codes[k] = 1_000_000_000 + 10_000 * z + 10 * a
    return codes[inverse.ravel()]


def write_kin_table(group: h5py.Group, primaries: Primaries) -> bool:
    """Write remage's ``kin`` table of ``primaries`` into ``group`` (see the module docstring);
    False (nothing written) when a particle has no PDG code."""
    codes = pdg_codes(primaries.particle)
    if codes is None:
        return False
    offsets = primaries.event_offsets()
    n_part = np.zeros(len(primaries), np.int32)
    n_part[offsets[:-1]] = np.diff(offsets)
    time = primaries.extra.get("time")
    columns = {
        "ekin": (primaries.energy, "MeV"),
        "g4_pid": (codes.astype(np.int32), None),
        "px": (primaries.direction[:, 0], None),
        "py": (primaries.direction[:, 1], None),
        "pz": (primaries.direction[:, 2], None),
        "time": (np.zeros(len(primaries)) if time is None else np.asarray(time) * 1e9, "ns"),
        "n_part": (n_part, None),
    }
    kin = group.create_group("kin")
    for name, (data, unit) in columns.items():
        d = kin.create_dataset(name, data=data)
        d.attrs["datatype"] = "array<1>{real}"
        if unit is not None:
            d.attrs["units"] = unit
    kin.attrs["datatype"] = "table{" + ",".join(columns) + "}"
    return True


def write_vertex_file(
    path: str | Path, primaries: Primaries, config: dict, seed: int, source: dict | None = None
) -> Path:
    """Write a vertex file atomically; ``source`` (JSON attribute ``source``) says where the
    vertices are: :func:`score4.source.build.source_geometry`, whose ``faces`` list names the
    values of the ``face`` column."""
    path = Path(path)
    with atomic_h5(path) as f:
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["config"] = json.dumps(config)
        if source is not None:
            f.attrs["source"] = json.dumps(source)
        f.attrs["seed"] = seed
        f.attrs["n_events"] = primaries.n_events
        write_primaries_table(f.create_group("vertices"), primaries)
        first = primaries.event_offsets()[:-1]  # the primaries of one event share its vertex
        pos = f.create_group("vtx/pos")
        for k, a in enumerate("xyz"):
            d = pos.create_dataset(f"{a}loc", data=primaries.position[first, k])
            d.attrs["datatype"], d.attrs["units"] = "array<1>{real}", "mm"
        pos.attrs["datatype"] = "table{xloc,yloc,zloc}"
        kin = write_kin_table(f["vtx"], primaries)
        f["vtx"].attrs["datatype"] = "struct{pos,kin}" if kin else "struct{pos}"
    return path


def vertex_file_config(path: str | Path) -> dict:
    """The configuration (JSON with units) a vertex file was drawn with; {} if unknown."""
    try:
        with h5py.File(path, "r") as f:
            return json.loads(f.attrs.get("config", "{}"))
    except (OSError, ValueError):
        return {}


def read_vertex_file(path: str | Path) -> Primaries:
    """Read the primaries of a vertex file; events must be numbered 0, 1, 2, ... in order."""
    path = Path(path)
    with open_h5(path, FORMAT, "source.vertices", ConfigError) as f:
        if "vertices" not in f:
            raise ConfigError(
                f"source.vertices: {path} has no /vertices table (write it with 'score4 vertices')"
            )
        try:
            p = read_primaries_table(f["vertices"], f"source.vertices: {path}")
        except KeyError as err:
            raise ConfigError(f"source.vertices: {path}: column {err} is missing") from None
    if len(p.event) and (
        p.event[0] != 0 or np.any(np.diff(p.event) < 0) or np.any(np.diff(p.event) > 1)
    ):
        raise ConfigError(f"source.vertices: {path}: events must be numbered 0, 1, 2, ... in order")
    _check_rows(p, f"source.vertices: {path}")
    return p


def _check_rows(p: Primaries, label: str) -> None:
    """Energies >= 0 (a nuclide decays at rest), directions of non-zero length, known particles."""
    from .emitters import normalise_particle

    bad = np.flatnonzero(~(p.energy >= 0))
    if len(bad):
        raise ConfigError(
            f"{label}: row {bad[0]} has energy {p.energy[bad[0]]:g} MeV; must be >= 0"
        )
    norm = np.linalg.norm(p.direction, axis=1)
    bad = np.flatnonzero(~(norm > 1e-12))
    if len(bad):
        raise ConfigError(f"{label}: row {bad[0]} has direction (0, 0, 0); give a direction")
    for name in np.unique(p.particle):
        try:
            normalise_particle(str(name))
        except ConfigError as err:
            raise ConfigError(f"{label}: {err}") from None
