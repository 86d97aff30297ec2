"""Measured topography files -> :class:`~score4.surface.heightmap.HeightMap` in mm.

:func:`read_topography` picks a reader from the file extension (or ``format``):

=================  =========================================================  =====================
format             files                                                      read with
=================  =========================================================  =====================
``x3p``            ISO 5436-2 / ISO 25178-72 XML container                    x3pio (metres)
``gwy``            Gwyddion native files                                      gwyfile (SI units)
``plu``            Sensofar PLu confocal / interferometric (one layer)        score4 (µm)
``plux``           Sensofar PLUx (zip container)                              surfalize (µm)
``sur``, ``sdf``   Digital Surf SUR, ISO 25178-71 SDF                         surfalize (µm)
others             al3d, vk4/6/7, opd, zmg, nms, tmd, os3d, lext, zon          surfalize (µm)
``txt``, ``csv``,  a matrix of heights, one row per y, with ``# key = value``  score4
``asc``            header lines (or keyword arguments) giving pitch and units
``xyz``            x y z point list on a regular grid (gaps become NaN)       score4
=================  =========================================================  =====================

Every reader converts to mm; the tests check each against an independent reader or the known
dimensions of the file. Rows of the map are y, columns x, as in HeightMap. Missing points are NaN.

Text grids (``txt``/``csv``/``asc``): numbers separated by whitespace, commas or semicolons;
lines starting with ``#`` are header lines ``# key = value`` (or ``key: value``). Keys:
``pitch`` / ``pitch_x`` / ``pitch_y`` (lengths with a unit, e.g. ``0.5 um``), ``z_unit`` (unit of
the heights: m, mm, um, nm, ...). Gwyddion's "ASCII data matrix" export header is understood too:
``Width`` / ``Height`` (whole extent = n * pitch) and ``Value units``. Keyword arguments override
the header. Without a pitch or a height unit the file is refused (no silent unit guess).

Sensofar ``.plu`` (binary, little-endian, no magic number; the layout that SurfaceTopography's
``PLUReader`` and Gwyddion's ``sensofar`` module read): a 500-byte header (128-byte date text,
uint32 time, 256-byte comment; calibration block with the grid size and µm per pixel in x and y;
measurement configuration with the measurement type, objective code, number of layers and number
of RGB images), then the layer: uint32 rows, uint32 columns, rows x columns float32 heights in µm
(row = y), float32 min and max, then the RGB images (3 bytes per point each). 1000001 marks a
point that was not measured (NaN). Only topographies (type 3) with one layer are read (a layer
count of 0, possible in old files, is read as one), and the file size must be exactly what the
header announces.

xyz lists: three columns x, y, z (more columns are ignored; non-numeric header lines and ``#``
lines are skipped). ``xy_unit`` and ``z_unit`` are required unless the header gives them. The
points must lie on a regular grid (coordinates within 1 % of a pitch of grid nodes, one point per
node); nodes without a point become NaN, but at least half of the nodes must have one.
"""

from __future__ import annotations

import math
import re
import struct
import warnings
from pathlib import Path

import numpy as np

from score4.common.units import LENGTH, parse_quantity

from ..errors import ConfigError
from .heightmap import HeightMap

TEXT_FORMATS = ("txt", "csv", "asc")
SURFALIZE_FORMATS = (
    "plux",
    "sur",
    "sdf",
    "al3d",
    "vk4",
    "vk6",
    "vk7",
    "opd",
    "zmg",
    "nms",
    "tmd",
    "os3d",
    "lext",
    "zon",
)
FORMATS = ("x3p", "gwy", "plu", *SURFALIZE_FORMATS, *TEXT_FORMATS, "xyz")
_M = LENGTH["m"]  # metres -> mm
_UM = LENGTH["um"]  # surfalize works in µm
_GRID_TOLERANCE = 0.01  # coordinates within this fraction of a pitch of a grid node
_MIN_GRID_FILL = 0.5  # at least this fraction of the grid nodes must hold a point


# ----------------------------------------------------------------------------- helpers
def _unit_factor(unit: str, name: str, where: Path) -> float:
    """mm per ``unit`` (a length unit name)."""
    u = unit.strip()
    if u not in LENGTH:
        raise ConfigError(
            f"{name}: unknown length unit {unit!r} for {where}; use one of: {', '.join(LENGTH)}"
        )
    return LENGTH[u]


def _pitch_value(value: float | str, name: str) -> float:
    p = parse_quantity(value, "length", name) if isinstance(value, str) else float(value)
    if not (math.isfinite(p) and p > 0):
        raise ConfigError(f"{name}: must be a positive length, got {value!r}")
    return p


def _import(module: str, fmt: str):
    try:
        return __import__(module, fromlist=["_"])
    except ImportError as exc:
        raise ConfigError(
            f"format: reading .{fmt} files needs the Python package {module.split('.')[0]!r} "
            f"(pip install {module.split('.')[0]})"
        ) from exc


def _heightmap(
    z: np.ndarray, px: float, py: float, path: Path, fmt: str, origin=(0.0, 0.0), **meta
) -> HeightMap:
    z = np.asarray(z, dtype=float)
    if z.ndim != 2 or min(z.shape) < 2:
        raise ConfigError(
            f"{path}: holds a {z.shape} array, not a surface; rule: at least 2 x 2 points"
        )
    if np.isnan(z).all():
        raise ConfigError(f"{path}: every point is missing (NaN); no valid measurement")
    try:
        return HeightMap(
            z,
            px,
            py,
            origin=(float(origin[0]), float(origin[1])),
            metadata={"source": str(path), "format": fmt, **meta},
        )
    except ConfigError as err:
        raise ConfigError(f"{path}: {err}") from None


# ------------------------------------------------------------------------ regular grids from points
def _grid_axis(v: np.ndarray, axis: str, path: Path) -> tuple[np.ndarray, float, float]:
    """Indices of coordinates on a regular axis, its pitch and start; ConfigError if not regular."""
    lo, span = float(v.min()), float(v.max() - v.min())
    if span == 0:
        raise ConfigError(
            f"{path}: all points share one {axis} value; rule: a grid needs at least 2 {axis} "
            "positions"
        )
    gaps = np.diff(np.unique(v))
    gaps = gaps[gaps > 1e-9 * span]  # merge round-off duplicates
    pitch = float(gaps.min())  # gaps of a gappy grid are multiples of the pitch
    pitch = span / max(round(span / pitch), 1)  # the pitch that lands exactly on the last node
    k = (v - lo) / pitch
    idx = np.rint(k).astype(np.int64)
    if np.max(np.abs(k - idx)) > _GRID_TOLERANCE:
        raise ConfigError(
            f"{path}: the {axis} coordinates are not on a regular grid; rule: every {axis} within "
            f"{_GRID_TOLERANCE:g} pitch of x0 + i * pitch (pitch {pitch:g})"
        )
    return idx, pitch, lo


def grid_from_points(
    x: np.ndarray, y: np.ndarray, z: np.ndarray, path: Path | str = "points"
) -> tuple[np.ndarray, float, float, tuple[float, float]]:
    """Detect the regular grid of a point list; return heights (ny, nx), pitch_x, pitch_y, origin.

    Grid nodes without a point are NaN. ConfigError for an empty list, points off a regular grid,
    two points on one node, or a grid less than half filled.
    """
    path = Path(path)
    x, y, z = (np.asarray(a, dtype=float).ravel() for a in (x, y, z))
    keep = np.isfinite(x) & np.isfinite(y)
    x, y, z = x[keep], y[keep], z[keep]
    if x.size == 0:
        raise ConfigError(
            f"{path}: contains no data points; rule: an x y z list needs at least 2 x 2 grid points"
        )
    i, px, x0 = _grid_axis(x, "x", path)
    j, py, y0 = _grid_axis(y, "y", path)
    nx, ny = int(i.max()) + 1, int(j.max()) + 1
    if x.size < _MIN_GRID_FILL * nx * ny:
        raise ConfigError(
            f"{path}: {x.size} points on a {nx} x {ny} grid; rule: at least {_MIN_GRID_FILL:.0%} "
            "of the grid nodes must hold a point (is it a scattered point cloud?)"
        )
    flat = j * nx + i
    if np.unique(flat).size != flat.size:
        raise ConfigError(
            f"{path}: two or more points fall on the same grid node; rule: one point per (x, y) "
            "node"
        )
    heights = np.full(ny * nx, np.nan)
    heights[flat] = z
    return heights.reshape(ny, nx), px, py, (x0, y0)


# ----------------------------------------------------------------------------- text files
_HEADER = re.compile(r"^\s*#\s*([^=:]+?)\s*[=:]\s*(.*?)\s*$")


def _split_text(path: Path) -> tuple[dict[str, str], list[str]]:
    """Header ``key = value`` pairs (lower-case keys) and the numeric data lines of a text file."""
    header: dict[str, str] = {}
    data: list[str] = []
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            m = _HEADER.match(stripped)
            if m:
                header[m.group(1).strip().lower()] = m.group(2)
            continue
        if not data and not re.match(r"^[-+.\d]|^nan", stripped, re.IGNORECASE):
            continue  # a column-title line before the numbers
        data.append(stripped)
    return header, data


def _parse_rows(lines: list[str], path: Path) -> np.ndarray:
    if not lines:
        raise ConfigError(f"{path}: contains no data points; rule: the file needs numeric rows")
    sep = "," if "," in lines[0] else ";" if ";" in lines[0] else None
    rows = [ln.replace(sep, " ").split() if sep else ln.split() for ln in lines]
    widths = {len(r) for r in rows}
    if len(widths) != 1:
        raise ConfigError(
            f"{path}: rows have different numbers of values {sorted(widths)}; rule: a rectangular "
            "table"
        )
    try:
        return np.array(rows, dtype=float)
    except ValueError as exc:
        raise ConfigError(f"{path}: non-numeric value in the data ({exc})") from exc


def _header_unit(
    header: dict[str, str], keys: tuple[str, ...], given: str | None, name: str, path: Path
) -> float:
    unit = given if given is not None else next((header[k] for k in keys if k in header), None)
    if unit is None:
        raise ConfigError(
            f"{name}: {path} does not say the unit of its values; give {name}= (e.g. 'um') "
            f"or a header line '# {name} = um'"
        )
    return _unit_factor(unit, name, path)


def _read_text_grid(path: Path, fmt: str, pitch, pitch_y, z_unit, **_) -> HeightMap:
    header, lines = _split_text(path)
    z = _parse_rows(lines, path)
    ny, nx = z.shape
    px = py = None
    if "width" in header:  # Gwyddion export: extents, pixel-size convention
        px = _pitch_value(header["width"], "Width") / nx
        py = _pitch_value(header.get("height", header["width"]), "Height") / ny
    px = _pitch_value(header["pitch"], "pitch") if "pitch" in header else px
    py = _pitch_value(header["pitch"], "pitch") if "pitch" in header else py
    px = _pitch_value(header["pitch_x"], "pitch_x") if "pitch_x" in header else px
    py = (
        _pitch_value(header["pitch_y"], "pitch_y")
        if "pitch_y" in header
        else (py if py is not None else px)
    )
    if pitch is not None:
        px = py = _pitch_value(pitch, "pitch")
    if pitch_y is not None:
        py = _pitch_value(pitch_y, "pitch_y")
    if px is None or py is None:
        raise ConfigError(
            f"pitch: {path} does not give the sample spacing; pass pitch='0.5 um' or add '# pitch "
            "= 0.5 um'"
        )
    factor = _header_unit(header, ("z_unit", "value units", "unit_z"), z_unit, "z_unit", path)
    return _heightmap(z * factor, px, py, path, fmt, header=header)


def _read_xyz(path: Path, fmt: str, xy_unit, z_unit, **_) -> HeightMap:
    header, lines = _split_text(path)
    if not lines:
        raise ConfigError(
            f"{path}: contains no data points; rule: an x y z list needs at least 2 x 2 grid points"
        )
    table = _parse_rows(lines, path)
    if table.shape[1] < 3:
        raise ConfigError(
            f"{path}: has {table.shape[1]} columns; rule: an xyz list needs columns x, y, z"
        )
    fxy = _header_unit(header, ("xy_unit", "unit_xy"), xy_unit, "xy_unit", path)
    fz = _header_unit(header, ("z_unit", "unit_z"), z_unit, "z_unit", path)
    z, px, py, origin = grid_from_points(
        table[:, 0] * fxy, table[:, 1] * fxy, table[:, 2] * fz, path
    )
    return _heightmap(z, px, py, path, fmt, origin=origin, header=header)


# --------------------------------------------------------------------------- library-backed formats
def _read_x3p(path: Path, fmt: str, **_) -> HeightMap:
    x3pio = _import("x3pio", fmt)
    try:
        data = x3pio.read(path)
    except Exception as exc:  # any failure of the reader is a bad file for the user
        raise ConfigError(f"{path}: cannot be read as x3p ({exc})") from exc
    kind = str(data.feature_type).split(".")[-1]
    if "PRF" in kind:
        raise ConfigError(
            f"{path}: holds a profile (FeatureType PRF), not a surface; rule: SUR or a gridded PCL"
        )
    layer = data.layers[0]
    meta = {"layers": len(data.layers), "feature_type": kind}
    if layer.is_regular_grid and "SUR" in kind:
        sx, sy = (
            layer.spacing if isinstance(layer.spacing, tuple) else (layer.spacing, layer.spacing)
        )
        return _heightmap(np.asarray(layer.z) * _M, sx * _M, sy * _M, path, fmt, **meta)
    pts = (
        np.asarray(layer.points()).reshape(-1, 3) * _M
    )  # absolute axes or point cloud: find the grid
    ok = np.isfinite(pts[:, 2])
    z, px, py, origin = grid_from_points(pts[ok, 0], pts[ok, 1], pts[ok, 2], path)
    return _heightmap(z, px, py, path, fmt, origin=origin, **meta)


def _si_factor(unit_obj, given: str | None, name: str, path: Path) -> float:
    unit = (
        given if given is not None else (unit_obj.get("unitstr") if unit_obj is not None else None)
    )
    if not unit:
        raise ConfigError(
            f"{name}: {path} has no {name.split('_')[0]} unit in the data field; pass {name}= "
            "(e.g. 'um')"
        )
    return _unit_factor(unit, name, path)


def _read_gwy(path: Path, fmt: str, xy_unit, z_unit, channel, **_) -> HeightMap:
    gwyfile = _import("gwyfile", fmt)
    try:
        fields = gwyfile.util.get_datafields(gwyfile.load(str(path)))
    except Exception as exc:
        raise ConfigError(f"{path}: cannot be read as a Gwyddion file ({exc})") from exc
    if not fields:
        raise ConfigError(f"{path}: contains no data field (channel)")
    if channel is None and len(fields) > 1:
        heights = [k for k, f in fields.items() if (f.get("si_unit_z") or {}).get("unitstr") == "m"]
        if len(heights) != 1:
            raise ConfigError(
                f"channel: {path} has channels {list(fields)}; choose one with channel="
            )
        channel = heights[0]
    title = channel if channel is not None else next(iter(fields))
    if title not in fields:
        raise ConfigError(f"channel: {title!r} is not in {path}; channels: {list(fields)}")
    f = fields[title]
    fxy = _si_factor(f.get("si_unit_xy"), xy_unit, "xy_unit", path)
    fz = _si_factor(f.get("si_unit_z"), z_unit, "z_unit", path)
    z = np.asarray(f.data, dtype=float)
    px, py = (
        f["xreal"] * fxy / z.shape[1],
        f["yreal"] * fxy / z.shape[0],
    )  # Gwyddion: real = res * pixel
    origin = (f.get("xoff", 0.0) * fxy, f.get("yoff", 0.0) * fxy)
    return _heightmap(z * fz, px, py, path, fmt, origin=origin, channel=title)


def _read_surfalize(path: Path, fmt: str, **_) -> HeightMap:
    common = _import("surfalize.file.common", fmt)
    try:
        raw = common.FileHandler(path, format_=f".{fmt}").read()
    except Exception as exc:
        raise ConfigError(
            f"{path}: cannot be read as .{fmt} ({type(exc).__name__}: {exc})"
        ) from exc
    return _heightmap(
        np.asarray(raw.data, dtype=float) * _UM,
        raw.step_x * _UM,
        raw.step_y * _UM,
        path,
        fmt,
        instrument_metadata={k: str(v) for k, v in (raw.metadata or {}).items()},
    )


# ----------------------------------------------------------------------------- Sensofar .plu
_PLU_HEADER = struct.Struct("<128sI256s3I7f5I5IdfII8BI")  # 500 bytes, fields below
_PLU_FIELDS = (
    "date",
    "time",
    "comment",
    "ny",
    "nx",
    "n_tall",
    "dy_multip",
    "um_per_pixel_x",
    "um_per_pixel_y",
    "x0",
    "y0",
    "um_per_pixel_z",
    "z0",
    "type",
    "algorithm",
    "method",
    "objective",
    "area_type",
    "scan_1",
    "scan_2",
    "scan_3",
    "scan_4",
    "scan_5",
    "scan_6",
    "scan_7",
    "scan_8",
    "scan_9",  # FOV or point scan
    "restore",
    "layers",
    "version",
    "hardware",
    "images",
    "reserved_1",
    "reserved_2",
    "reserved_3",
    "factor_delmacio",
)
_PLU_LAYER = struct.Struct("<2I")  # rows, columns
_PLU_TOPOGRAPHY = 3
_PLU_TYPES = {
    0: "image",
    1: "profile",
    2: "multi-profile",
    3: "topography",
    4: "coordinates",
    5: "thickness",
    6: "custom",
}
_PLU_NOT_MEASURED = 1000001.0


def _plu_text(raw: bytes) -> str:
    return raw.split(b"\0", 1)[0].decode("latin-1").strip()


def _read_plu(path: Path, fmt: str, **_) -> HeightMap:
    """Sensofar .plu topography (one layer) -> HeightMap; ConfigError for anything else."""
    data = path.read_bytes()
    start = _PLU_HEADER.size + _PLU_LAYER.size
    if len(data) < start:
        raise ConfigError(
            f"{path}: truncated .plu file ({len(data)} bytes); rule: header and layer size need "
            f"at least {start} bytes"
        )
    h = dict(zip(_PLU_FIELDS, _PLU_HEADER.unpack_from(data), strict=True))
    if h["type"] != _PLU_TOPOGRAPHY:
        kind = _PLU_TYPES.get(h["type"], "unknown")
        raise ConfigError(
            f"{path}: .plu measurement type {h['type']} ({kind}) is not supported; rule: only "
            f"topographies (type {_PLU_TOPOGRAPHY}) are read"
        )
    if h["layers"] > 1:
        raise ConfigError(
            f"{path}: .plu file holds {h['layers']} layers; rule: only single-layer files are read"
        )
    ny, nx = _PLU_LAYER.unpack_from(data, _PLU_HEADER.size)
    if (ny, nx) != (h["ny"], h["nx"]) or min(ny, nx) < 2:
        raise ConfigError(
            f"{path}: .plu layer size {ny} x {nx} (rows x columns) does not match the calibration "
            f"block's {h['ny']} x {h['nx']}; rule: equal sizes of at least 2 x 2"
        )
    expected = start + 4 * ny * nx + 8 + 3 * ny * nx * h["images"]  # heights, min/max, RGB images
    if len(data) != expected:
        what = "truncated" if len(data) < expected else "too long"
        raise ConfigError(
            f"{path}: .plu file is {what} ({len(data)} bytes); rule: a {ny} x {nx} layer with "
            f"{h['images']} RGB image(s) makes a file of exactly {expected} bytes"
        )
    px, py = h["um_per_pixel_x"], h["um_per_pixel_y"]
    if not (math.isfinite(px) and px > 0 and math.isfinite(py) and py > 0):
        raise ConfigError(
            f"{path}: .plu pixel size {px!r} x {py!r} um; rule: positive finite um/pixel in x and y"
        )
    z = np.frombuffer(data, dtype="<f4", count=ny * nx, offset=start).reshape(ny, nx).astype(float)
    z[(z == _PLU_NOT_MEASURED) | ~np.isfinite(z)] = np.nan
    z_min, z_max = struct.unpack_from("<2f", data, start + 4 * ny * nx)
    meta = {
        "date": _plu_text(h["date"]),
        "time": h["time"],
        "comment": _plu_text(h["comment"]),
        "objective": h["objective"],  # Sensofar's objective code (the instrument's own table)
        "layers": max(h["layers"], 1),
        "images": h["images"],
        "algorithm": h["algorithm"],
        "method": h["method"],
        "area_type": h["area_type"],
        "version": h["version"],
        "hardware": h["hardware"],
        "offset_um": (h["x0"], h["y0"], h["z0"]),
        "stored_min_max_um": (z_min, z_max),
    }
    return _heightmap(z * _UM, px * _UM, py * _UM, path, fmt, **meta)


# ----------------------------------------------------------------------------- entry point
def format_of(path: Path, format: str | None) -> str:
    """The reader's name for ``format``, or the one ``path``'s extension names; else ConfigError."""
    fmt = (format if format is not None else path.suffix).lower().lstrip(".")
    if fmt not in FORMATS:
        what = (
            f"format {format!r}" if format is not None else f"extension {path.suffix!r} of {path}"
        )
        raise ConfigError(f"format: unknown {what}; known formats: {', '.join(FORMATS)}")
    return fmt


def read_topography(
    path: str | Path,
    format: str | None = None,
    *,
    pitch: float | str | None = None,
    pitch_y: float | str | None = None,
    xy_unit: str | None = None,
    z_unit: str | None = None,
    channel: str | None = None,
) -> HeightMap:
    """Read a measured topography file into a HeightMap in mm.

    Parameters
    ----------
    path
        The file.
    format
        One of :data:`FORMATS` (without dot); default: from the file extension.
    pitch, pitch_y
        Text grids: sample spacing (mm, or string with unit), overriding the header.
    xy_unit, z_unit
        Unit names (``"m"``, ``"um"``, ``"nm"``, ...) for text/xyz files, or for Gwyddion files
        whose data field carries no unit.
    channel
        Gwyddion files: the title of the data field to read (default: the only one, or the only
        one with heights in metres).

    Returns
    -------
    HeightMap
        ``metadata`` holds ``source`` (the path), ``format`` and what the reader found.
    """
    path = Path(path)
    fmt = format_of(path, format)
    if not path.is_file():
        raise ConfigError(f"path: {path} does not exist or is not a file")
    reader = (
        _read_x3p
        if fmt == "x3p"
        else _read_gwy
        if fmt == "gwy"
        else _read_plu
        if fmt == "plu"
        else _read_xyz
        if fmt == "xyz"
        else _read_text_grid
        if fmt in TEXT_FORMATS
        else _read_surfalize
    )
    with warnings.catch_warnings():
        warnings.filterwarnings(
            "ignore", message=".*different pixel size.*"
        )  # surfalize: fine for HeightMap
        return reader(
            path, fmt, pitch=pitch, pitch_y=pitch_y, xy_unit=xy_unit, z_unit=z_unit, channel=channel
        )
