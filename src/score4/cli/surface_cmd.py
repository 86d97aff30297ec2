"""``score4 surface``: generate, measure, picture and export rough surfaces.

FILE arguments are recognised by name: ``*.h5`` / ``*.hdf5`` is a score4 surface file
(:mod:`score4.surface.store`), ``*.yaml`` / ``*.yml`` a surface description
(:mod:`score4.surface.spec`, built on the fly), and any extension known to
:func:`~score4.surface.readers.read_topography` a measured topography file.

Errors caused by input are raised as :class:`~score4.errors.Score4Error`;
:func:`score4.cli.main.main` prints them as one line ``score4: error: <message>`` and returns 2.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import click

from score4.common.schema import input_paths, quantity
from score4.common.units import um

from ..errors import ConfigError
from ..files import check_output_file, check_outputs

__all__ = ["load_any", "stats_document", "surface"]

SURFACE_FILE_SUFFIXES = (".h5", ".hdf5")
DESCRIPTION_SUFFIXES = (".yaml", ".yml")
#: Unit of each ISO 25178 unit kind of :data:`score4.surface.metrology.PARAMETERS` in the output.
OUTPUT_UNITS = {"length": "um", "ratio": "dimensionless", "percent": "%"}


def _file_kind(path: Path) -> str:
    """'surface', 'description' or 'topography', from the file name; ConfigError otherwise."""
    from ..surface.readers import FORMATS

    name = path.name.lower()
    if not path.exists():
        raise ConfigError(f"FILE: {str(path)!r} does not exist")
    if not path.is_file():
        raise ConfigError(f"FILE: {str(path)!r} is not a file")
    if name.endswith(SURFACE_FILE_SUFFIXES):
        return "surface"
    if name.endswith(DESCRIPTION_SUFFIXES):
        return "description"
    if path.suffix.lower().lstrip(".") in FORMATS:
        return "topography"
    raise ConfigError(
        f"FILE: cannot tell what {str(path)!r} is from its extension {path.suffix!r}; expected a "
        "surface file (.s4s.h5), a description (.yaml/.yml) or a topography file "
        f"({', '.join(FORMATS)})"
    )


def load_any(path: str | Path):
    """A :class:`~score4.surface.spec.Surface` from a surface file, a description or a topography
    file.

    A topography file is taken with the defaults of a ``kind: measured`` description (plane
    levelled; missing points refused): write a description to change them.
    """
    from ..surface.spec import build_surface, load_surface_spec, parse_surface_spec
    from ..surface.store import load_surface

    path = Path(path)
    kind = _file_kind(path)
    if kind == "surface":
        return load_surface(path)
    if kind == "description":
        return build_surface(load_surface_spec(path))
    try:
        return build_surface(
            parse_surface_spec({"kind": "measured", "file": str(path)}, origin=str(path))
        )
    except ConfigError as err:
        raise ConfigError(
            f"{err} (in a surface description with kind: measured and file: {path.name})"
        ) from None


def _in_output_units(values: dict[str, float]) -> dict[str, float | None]:
    """Lengths mm -> um; NaN -> None (JSON has no NaN)."""
    from ..surface.metrology import PARAMETERS

    kinds = {symbol: kind for symbol, kind, _ in PARAMETERS}
    out: dict[str, float | None] = {}
    for symbol, value in values.items():
        v = float(value) / um if kinds[symbol] == "length" else float(value)
        out[symbol] = v if math.isfinite(v) else None
    return out


def stats_document(path: str | Path) -> dict[str, Any]:
    """The ``score4 surface stats --json`` document of a surface, description or topography file.

    Keys: every ISO symbol of :data:`~score4.surface.metrology.PARAMETERS` (lengths in um, Sdr
    in %, others dimensionless; None where undefined), ``units`` (symbol -> unit), ``surface``
    (file, kind, size and map shape) and ``exact`` (the symbols whose top-level value is exact).
    For spike grids the top-level values of :data:`~score4.surface.metrology.MESH_PARAMETERS`
    are the exact values on the triangle mesh (Sal and Str, which need the autocorrelation, come
    from the map), and ``map`` holds every parameter of the sampled height map. For height maps
    (random, measured) the map is the surface: all values are map values, ``exact`` is empty.
    Periodic maps count one period (their duplicated closing edge is left out).
    """
    from ..surface.metrology import PARAMETERS, areal_parameters, mesh_parameters
    from ..surface.readers import read_topography

    path = Path(path)
    spikes = None
    if _file_kind(path) == "topography":
        # The raw file as measured: missing points are left out of the parameters, not refused.
        hm = read_topography(path)
        kind = f"topography ({hm.metadata.get('format', path.suffix.lstrip('.'))})"
    else:
        surface = load_any(path)
        hm, kind, spikes = surface.map, surface.spec.kind, surface.spikes
    map_values = _in_output_units(areal_parameters(hm))
    exact = _in_output_units(mesh_parameters(surface.top_mesh)) if spikes is not None else {}
    doc: dict[str, Any] = {**map_values, **exact}
    doc["exact"] = list(exact)
    doc["units"] = {symbol: OUTPUT_UNITS[unit] for symbol, unit, _ in PARAMETERS}
    doc["surface"] = {
        "file": str(path),
        "kind": kind,
        "size_x_um": hm.size_x / um,
        "size_y_um": hm.size_y / um,
        "map_points": list(hm.shape),
        "map_pitch_um": [hm.pitch_x / um, hm.pitch_y / um],
    }
    if spikes is not None:
        doc["map"] = map_values
        doc["surface"]["n_spikes"] = int(spikes.n_spikes)
    return doc


@click.group("surface")
def surface() -> None:
    """Generate, measure, picture and export rough surfaces.

    FILE is a surface file (.s4s.h5), a surface description (.yaml) or a measured topography
    file (x3p, gwy, sdf, txt, xyz, ...).
    """


@surface.command("generate")
@click.argument(
    "description", metavar="DESCRIPTION.yaml", type=click.Path(dir_okay=False, path_type=Path)
)
@click.option(
    "--out",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Surface file to write (.s4s.h5); default: <description name>.s4s.h5 here.",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing surface file.")
def generate_cmd(description: Path, out: Path | None, overwrite: bool) -> None:
    """Build the surface DESCRIPTION.yaml asks for and save it as a score4 surface file."""
    from ..surface.plot import headline_sq
    from ..surface.spec import build_surface, load_surface_spec
    from ..surface.store import SUFFIX, save_surface

    out = out or Path(description.name.rsplit(".", 1)[0] + SUFFIX)
    if not out.name.lower().endswith(SURFACE_FILE_SUFFIXES):
        raise ConfigError(
            f"--out: {str(out)!r} must end with {SUFFIX} (an HDF5 score4 surface file)"
        )
    spec = load_surface_spec(description)
    check_output_file(
        out, overwrite, "--out", {"the description": description, **input_paths(spec)}
    )
    built = build_surface(spec)
    save_surface(built, out)
    sq, how = headline_sq(built)
    click.echo(
        f"wrote {out}: {built.spec.kind}, {built.size_x / um:.6g} x {built.size_y / um:.6g} um, "
        f"{built.top_mesh.n_faces} top mesh facets, Sq {sq / um:.4g} um ({how})"
    )


@surface.command("stats")
@click.argument("file", metavar="FILE", type=click.Path(path_type=Path))
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="Machine-readable JSON: ISO symbols as keys (exact mesh values for spike grids), "
    "'units', 'exact', and 'map' (sampled-map values) for spike grids.",
)
def stats_cmd(file: Path, as_json: bool) -> None:
    """Print the ISO 25178-2 areal parameters of FILE.

    Spike grids: the exact values on the triangle mesh (Sal and Str from the height map,
    sampled exactly at 1/16 of a cell), with the sampled map's values beside them. Height maps
    (random, measured): the map's values; periodic maps count one period. Units: Sa Sq Sp Sv Sz
    Sal in um; Sdr in %; Ssk, Sku (3 for a Gaussian surface), Sdq and Str dimensionless.
    Undefined values (e.g. Sal when the autocorrelation never decays below 0.2) are shown as
    nan (null in JSON).
    """
    from ..surface.metrology import PARAMETERS

    doc = stats_document(file)
    if as_json:
        click.echo(json.dumps(doc, indent=2))
        return
    info = doc["surface"]
    ny, nx = info["map_points"]
    click.echo(
        f"{info['file']}: {info['kind']}, {info['size_x_um']:.6g} x {info['size_y_um']:.6g} um, "
        f"map {nx} x {ny} points"
    )
    sampled = doc.get("map")
    show = lambda v: "nan" if v is None else f"{v:.6g}"  # noqa: E731
    header = f"  {'param':<6}{'value':>12}" + (f"{'map':>12}" if sampled else "")
    click.echo(header + f"  {'unit':<14}description")
    for symbol, _, text in PARAMETERS:
        beside = f"{show(sampled[symbol]):>12}" if sampled else ""
        how = " (exact, mesh)" if symbol in doc["exact"] else (" (map)" if sampled else "")
        unit = doc["units"][symbol]
        click.echo(f"  {symbol:<6}{show(doc[symbol]):>12}{beside}  {unit:<14}{text}{how}")


@surface.command("show")
@click.argument("file", metavar="FILE", type=click.Path(path_type=Path))
@click.option(
    "--png",
    "png",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="PNG file to write.",
)
@click.option(
    "--dpi",
    type=click.IntRange(min=20, max=1200),
    default=150,
    show_default=True,
    help="Resolution of the PNG.",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing PNG file.")
def show_cmd(file: Path, png: Path, dpi: int, overwrite: bool) -> None:
    """Draw FILE: height-map image (with colour bar and scale bar) and a 3D view, as a PNG."""
    from ..surface.plot import plot_surface

    check_outputs({"--png": png}, overwrite, {"the surface file": file}, images=("--png",))
    plot_surface(load_any(file), png, dpi=dpi)
    click.echo(f"wrote {png}")


@surface.command("export")
@click.argument("file", metavar="FILE", type=click.Path(path_type=Path))
@click.option(
    "--stl", type=click.Path(dir_okay=False, path_type=Path), help="Write a binary STL (mm)."
)
@click.option(
    "--ply",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write a binary PLY (mm, float64).",
)
@click.option(
    "--gdml", type=click.Path(dir_okay=False, path_type=Path), help="Write a standalone GDML file."
)
@click.option(
    "--base-thickness",
    default="1 um",
    show_default=True,
    help="Slab under the base plane z = 0 that closes the body (a length with unit).",
)
@click.option(
    "--solid",
    "solid_kind",
    type=click.Choice(["tessellated", "multiunion"]),
    default="tessellated",
    show_default=True,
    help="GDML solid: G4TessellatedSolid of the body, or (spike grids) the paper's G4MultiUnion.",
)
@click.option(
    "--material", default="G4_Si", show_default=True, help="GDML: NIST material of the solid."
)
@click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
def export_cmd(
    file: Path,
    stl: Path | None,
    ply: Path | None,
    gdml: Path | None,
    base_thickness: str,
    solid_kind: str,
    material: str,
    overwrite: bool,
) -> None:
    """Export the closed body of FILE (rough top on a base slab) as STL, PLY or GDML.

    Give exactly one of --stl, --ply and --gdml. The body is centred on the origin in x and y,
    with the rough top above z = 0 and the slab from -base-thickness to 0 (lengths in mm).
    """
    from score4.surface.triangle_mesh import write_ply, write_stl

    chosen = [
        (name, p) for name, p in (("stl", stl), ("ply", ply), ("gdml", gdml)) if p is not None
    ]
    if len(chosen) != 1:
        given = ", ".join(f"--{n}" for n, _ in chosen) or "none"
        raise ConfigError(f"export: give exactly one of --stl, --ply and --gdml (got {given})")
    fmt, out = chosen[0]
    thickness = quantity(base_thickness, "length", "--base-thickness", positive=True)
    if solid_kind == "multiunion" and fmt != "gdml":
        raise ConfigError(
            f"--solid: 'multiunion' is a Geant4 solid and applies to --gdml only, not --{fmt}"
        )
    check_outputs({f"--{fmt}": out}, overwrite, {"the surface file": file})
    built = load_any(file)
    if solid_kind == "multiunion" and built.spikes is None:
        raise ConfigError(
            f"--solid: 'multiunion' needs a spike grid; {str(file)!r} is a {built.spec.kind} "
            "surface"
        )
    body = built.body(thickness) if solid_kind == "tessellated" else None
    if fmt in ("stl", "ply"):
        assert body is not None  # multiunion applies to --gdml only (checked above)
        (write_stl if fmt == "stl" else write_ply)(body, out)
    else:
        from ..sim.export_surface import export_surface_gdml

        spikes = built.spikes if solid_kind == "multiunion" else None
        export_surface_gdml(spikes, body, out, thickness, material)
    facets = (
        f"{body.n_faces} facets"
        if body is not None
        else f"{len(built.spikes.frustums()) + 1} G4MultiUnion nodes"
    )
    click.echo(
        f"wrote {out}: {built.spec.kind} body, {facets}, base thickness {thickness / um:.6g} um"
    )
