"""``score4 data``: show and install the Geant4 data sets.

Errors caused by input (:class:`~score4.errors.Score4Error`) are printed as one line
``score4: error: <message>`` on stderr and end the command with exit status 2
(``click.exceptions.Exit(2)``).
"""

from __future__ import annotations

import functools
import json
import shlex
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

import click

from score4.errors import Score4Error
from score4.runner import datasets

from .quiet import is_quiet

__all__ = ["data"]

F = TypeVar("F", bound=Callable[..., Any])


def _reports_errors(func: F) -> F:
    """Turn a Score4Error into one line on stderr and exit status 2."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except Score4Error as exc:
            click.echo(f"score4: error: {exc}", err=True)
            raise click.exceptions.Exit(2) from exc

    return wrapper  # type: ignore[return-value]


def _status_dict(statuses: Sequence[datasets.DataSetStatus]) -> dict[str, Any]:
    """The ``status --json`` document."""
    available = datasets.available_modes(statuses)
    return {
        "datasets": [s.to_dict() for s in statuses],
        "modes": {
            mode: {"available": ok, "missing": datasets.missing_for(mode, statuses)}
            for mode, ok in available.items()
        },
        "default_dir": str(datasets.default_data_dir()),
    }


def _table(rows: Sequence[Sequence[str]]) -> list[str]:
    """Left-aligned text columns."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return [
        "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
        for row in rows
    ]


def _source_text(s: datasets.DataSetStatus) -> str:
    if s.source is datasets.Source.ENVVAR:
        return f"${s.envvar}"
    if s.source is datasets.Source.GEANT4_DATA_DIR:
        return "$GEANT4_DATA_DIR"
    if s.source is datasets.Source.GEANT4_PYBIND:
        return "~/.geant4_pybind"
    return "score4 data dir" if s.source is datasets.Source.SCORE4 else "-"


def _print_status(statuses: Sequence[datasets.DataSetStatus]) -> None:
    rows = [("NAME", "VERSION", "FOUND AT", "SOURCE")]
    rows += [
        (s.name, s.version, str(s.path) if s.path else "MISSING", _source_text(s)) for s in statuses
    ]
    for line in _table(rows):
        click.echo(line)
    click.echo("")
    click.echo("physics modes:")
    for mode, ok in datasets.available_modes(statuses).items():
        missing = datasets.missing_for(mode, statuses)
        if ok:
            click.echo(f"  {mode:<6} available")
        else:
            click.echo(
                f"  {mode:<6} missing {', '.join(missing)}  "
                f"(install with: score4 data install --mode {mode})"
            )


@click.group("data")
def data() -> None:
    """Show or install the Geant4 data sets that full physics and radioactive decay need."""


@data.command("status")
@click.option("--json", "as_json", is_flag=True, help="Print the status as JSON.")
@_reports_errors
def status_cmd(as_json: bool) -> None:
    """List the official data sets, where each was found, and the physics modes they allow."""
    statuses = datasets.status()
    if as_json:
        click.echo(json.dumps(_status_dict(statuses), indent=2))
    else:
        _print_status(statuses)


def _elsewhere(directory: Path) -> list[datasets.DataSetStatus]:
    """Sets found outside ``directory`` that GEANT4_DATA_DIR alone would not reach."""
    reach = (datasets.Source.ENVVAR,)
    return [
        s
        for s in datasets.status()
        if s.path is not None and s.source not in reach and s.path.parent != directory
    ]


@data.command("install")
@click.option(
    "--dir",
    "directory",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Target folder (default: $SCORE4_DATA_DIR or $XDG_DATA_HOME/score4/geant4-data).",
)
@click.option(
    "--only",
    "only",
    multiple=True,
    metavar="NAME",
    help="Install only this data set (repeatable). Default: all missing ones.",
)
@click.option(
    "--mode",
    type=click.Choice(["full", "decay"]),
    default=None,
    help="Install what this physics mode still needs.",
)
@click.option(
    "--url",
    default=None,
    metavar="URL",
    help="Server folder holding the tarballs (default: $SCORE4_DATASET_URL or CERN).",
)
@click.option("--no-progress", is_flag=True, help="Do not show progress bars.")
@_reports_errors
def install_cmd(
    directory: Path | None,
    only: tuple[str, ...],
    mode: str | None,
    url: str | None,
    no_progress: bool,
) -> None:
    """Download, verify (md5) and unpack official Geant4 data sets."""
    target = (directory or datasets.default_data_dir()).expanduser().absolute()
    names = list(only)
    if mode is not None:
        names += [n for n in datasets.missing_for(mode, datasets.status()) if n not in names]
        if not names:
            click.echo(f"everything physics mode {mode!r} needs is installed")
            return
    progress = not (no_progress or is_quiet())
    paths = datasets.install(target, only=names or None, base_url=url, progress=progress)
    for path in paths:
        click.echo(f"ready: {path}")
    if not paths:
        click.echo("nothing to install: every official data set was found")
    for s in _elsewhere(target):
        where = shlex.quote(str(s.path))
        click.echo(f"note: {s.name} is at {s.path}; also: export {s.envvar}={where}")
    click.echo(datasets.export_line(target))
