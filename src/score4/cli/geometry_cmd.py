"""``score4 geometry check``: build a run's geometry and let Geant4 look for overlaps."""

from __future__ import annotations

import tempfile
from pathlib import Path

import click


@click.group()
def geometry() -> None:
    """Inspect the Geant4 geometry a run configuration builds."""


@geometry.command()
@click.argument(
    "config_file", metavar="CONFIG.yaml", type=click.Path(dir_okay=False, path_type=Path)
)
@click.option(
    "--points",
    type=click.IntRange(min=10),
    default=1000,
    show_default=True,
    help="Surface points per placement that Geant4 tests.",
)
@click.option(
    "--max-placements",
    type=click.IntRange(min=1),
    default=500,
    show_default=True,
    help="Rough layers with more patches get the exact cell-containment check instead.",
)
@click.option(
    "--tolerance", default="0 nm", show_default=True, help="Overlaps up to this depth are ignored."
)
@click.option(
    "--log",
    "log_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Keep Geant4's output here (appended to an existing file).",
)
def check(config_file: Path, points: int, max_placements: int, tolerance: str, log_path) -> None:
    """Check CONFIG.yaml's volumes for overlaps (Geant4 CheckOverlaps). Exit status 1 if any
    overlap."""
    from score4.common.schema import input_paths, quantity
    from score4.inputs.config import allowing_overlaps, load_config
    from score4.runner.run_plan import plan_run

    from ..errors import naming_file
    from ..files import check_outputs
    from ..sim.geometry_check import check_geometry
    from ..sim.runtime import resolve_physics

    config = allowing_overlaps(load_config(config_file))  # the check reports them itself
    tol = quantity(tolerance, "length", "--tolerance", non_negative=True)
    # --log appends to an existing file, but never to an input
    check_outputs(
        {"--log": log_path}, True, {"the configuration": config_file, **input_paths(config)}
    )
    lite = resolve_physics("lite")  # geometry needs no physics data
    with naming_file(config_file):
        plan = plan_run(config, physics=lite, source=False)
    with tempfile.TemporaryDirectory() as tmp:
        log = log_path or Path(tmp) / "geant4.log"
        # Geant4 in a process of its own: each check has its own stores (sim.geometry_check)
        with naming_file(config_file):
            report = check_geometry(plan, points, tol, max_placements, log)
        click.echo(
            f"Geant4 checked {report.checked} of {report.total} placements with {points} points "
            "each"
            + (
                f"; {report.exact} patch placements of large layers by exact cell containment"
                if report.exact
                else ""
            )
            + (
                f"; {report.curved} cells of curved layers by exact tiling, Geant4 on "
                f"{report.sampled} placements of sampled neighbourhoods"
                if report.curved
                else ""
            )
        )
        if report.no_points:
            click.echo(
                f"{len(report.no_points)} solid(s) Geant4 cannot put points on (thin boolean "
                f"cells; the exact tiling covers them): {', '.join(report.no_points[:4])}"
                + (" ..." if len(report.no_points) > 4 else "")
            )
        if report.false_reports:
            click.echo(
                f"{len(report.false_reports)} Geant4 report(s) between tessellated bodies are "
                "not overlaps (re-tested exactly):"
            )
            for line in report.false_reports[:10]:
                click.echo(f"  {line}")
            if len(report.false_reports) > 10:
                click.echo("  ...")
        if report.ok:
            click.echo("no overlaps")
            return
        click.echo(
            f"{len(report.overlaps)} placement(s) overlap: {', '.join(report.overlaps[:10])}"
            + (" ..." if len(report.overlaps) > 10 else ""),
            err=True,
        )
        details = [
            line for line in log.read_text(errors="replace").splitlines() if "verlap" in line
        ]
        for line in details[:20]:
            click.echo(f"  {line.strip()}", err=True)
    raise click.exceptions.Exit(1)


def _bare_gdml(path: Path) -> Path | None:
    """The GDML file to list when ``path`` is one, or a YAML file holding only ``world: {gdml:
    FILE}`` (no targets yet); else None."""
    from ..errors import ConfigError

    if path.suffix.lower() in (".gdml", ".xml"):
        return path
    if not path.is_file():
        return None
    from score4.common.yamlfile import load_yaml

    data = load_yaml(path, "config")
    if isinstance(data, dict) and "targets" not in data and "source" not in data:
        world = data.get("world")
        gdml = world.get("gdml") if isinstance(world, dict) else None
        if not isinstance(gdml, str):
            raise ConfigError(
                f"{path}: world.gdml: give the GDML file to list (world: {{gdml: FILE}}), or "
                "a whole run configuration"
            )
        return path.parent / gdml
    return None


def _gdml_rows(path: Path, parameter: str) -> dict:
    from score4.world.gdml_files import load_geometry_model

    model = load_geometry_model(path, parameter)
    return {
        "world": str(path),
        "volumes": list(model.rows()),
        "truncated": bool(model.truncated),
        "overlaps": model.overlaps,
        "targets": [],
    }


@geometry.command(name="list")
@click.argument(
    "config_file", metavar="CONFIG.yaml|FILE.gdml", type=click.Path(dir_okay=False, path_type=Path)
)
@click.option("--json", "as_json", is_flag=True, help="One JSON object per volume, as a list.")
@click.option(
    "--faces",
    "with_faces",
    is_flag=True,
    help="Also list each target's faces with their areas, and its face groups.",
)
def list_volumes(config_file: Path, as_json: bool, with_faces: bool) -> None:
    """List the volumes of a world: name[copy], solid, material, mass, area, position.

    Give a GDML file (every physical volume, indented by depth, and any overlaps of its own
    volumes), a YAML file with only world: {gdml: FILE}, or a run configuration (its world,
    then the targets with their rough faces; for a generated world the targets). With
    --faces, each target's faces (the names rough faces and surface sources take) and groups.
    """
    import json

    from score4.inputs.config import allowing_overlaps, load_config
    from score4.world.listing import geometry_rows, geometry_text
    from score4.world.resolve import build_scene

    from ..errors import naming_file

    gdml = _bare_gdml(config_file)
    if gdml is not None:
        if gdml == config_file:
            rows = _gdml_rows(gdml, "FILE.gdml")
        else:
            with naming_file(config_file):
                rows = _gdml_rows(gdml, "world.gdml")
    else:
        config = allowing_overlaps(load_config(config_file))  # the listing shows them
        with naming_file(config_file):
            scene = build_scene(config)
        rows = geometry_rows(scene, with_faces)
        rows["overlaps"] = scene.model.overlaps if scene.model is not None else []
    if as_json:
        click.echo(json.dumps(rows, indent=1))
        return
    click.echo(geometry_text(rows, with_faces))


@geometry.command(name="export")
@click.argument(
    "config_file", metavar="CONFIG.yaml", type=click.Path(dir_okay=False, path_type=Path)
)
@click.option(
    "--gdml",
    "out",
    type=click.Path(dir_okay=False, path_type=Path),
    required=True,
    help="GDML file to write: the whole world with its rough layers.",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing file.")
@click.option(
    "--allow-overlaps", is_flag=True, help="Export although the GDML world's own volumes overlap."
)
def export_gdml(config_file: Path, out: Path, overwrite: bool, allow_overlaps: bool) -> None:
    """Write CONFIG.yaml's world with its rough layers as GDML (for remage, your own Geant4
    application, pyg4ometry). Vertices from 'score4 vertices' are in this world's frame."""
    from score4.common.schema import input_paths
    from score4.inputs.config import allowing_overlaps, load_config
    from score4.world.resolve import build_scene

    from ..errors import naming_file
    from ..files import check_outputs
    from ..sim.export_world import export_world

    config = load_config(config_file)
    if allow_overlaps:
        config = allowing_overlaps(config)
    check_outputs(
        {"--gdml": out}, overwrite, {"the configuration": config_file, **input_paths(config)}
    )
    with naming_file(config_file):
        build_scene(config)  # bad input fails here, before any Geant4 process
        info = export_world(config, out)
    click.echo(
        f"wrote {out}: {info['size'] / 1e6:.3g} MB, rough layers: "
        f"{', '.join(info['layers']) or 'none'}"
    )
    if info.get("registered"):
        click.echo(
            "rough layers registered with their remage detectors (RMG_detector, UID reused): "
            + ", ".join(info["registered"])
        )
