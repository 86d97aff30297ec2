"""``score4 import-macro``: convert an original SCoRe4 Geant4 macro into a score4 run configuration.

Errors caused by input are raised as :class:`~score4.errors.ConfigError`;
:func:`score4.cli.main.main` prints them as one line ``score4: error: <message>`` and returns 2.
"""

from __future__ import annotations

from pathlib import Path

import click

from ..errors import ConfigError
from .quiet import notice

__all__ = ["import_macro"]


@click.command("import-macro")
@click.argument("macro", metavar="FILE.mac", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "--out",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Run configuration to write (CONFIG.yaml).",
)
@click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
@click.option(
    "--strict", is_flag=True, help="Fail (exit 2, nothing written) if any command is not converted."
)
def import_macro(macro: Path, out: Path, overwrite: bool, strict: bool) -> None:
    """Convert an original SCoRe4 macro (FILE.mac) into a score4 run configuration.

    RoughnessHelper / MultiportalHelper / /geometry/surface settings become a spike surface on
    the face of a target (half-lengths are doubled: score4 uses full lengths), /shift/ the depth
    profile, /gps/ the emitter, /run/beamOn and /random/setSeeds the run. What the macro cannot
    say is filled with defaults; the written YAML lists them, line by line, in its header.
    Commands that are not converted are printed as warnings (errors with --strict).
    """
    from ..files import check_output_file
    from ..macro import import_macro as convert
    from ..macro import write_config

    check_output_file(out, overwrite, "--out", {"the macro": macro})
    config, report = convert(macro, out=out)
    for item in sorted(report.unknown, key=lambda i: i.order):
        notice(
            f"score4: warning: {macro} {item.where}: {item.command}: not converted ({item.detail})"
        )
    if strict and report.unknown:
        listed = "; ".join(
            f"{i.where} {i.command.split()[0]}"
            for i in sorted(report.unknown, key=lambda i: i.order)
        )
        raise ConfigError(
            f"{macro}: {len(report.unknown)} command(s) not converted (--strict; nothing written): "
            f"{listed}"
        )
    written = write_config(config, report, out, overwrite=overwrite)
    for line in report.lines():
        click.echo(line)
    extra = f" and {', '.join(str(p) for p in written[1:])}" if len(written) > 1 else ""
    click.echo(
        f"wrote {out}{extra} from {macro}: {len(report.converted)} command(s) converted, "
        f"{len(report.ignored)} ignored, {len(report.defaults)} default(s) filled in, "
        f"{len(report.unknown)} not converted"
    )
