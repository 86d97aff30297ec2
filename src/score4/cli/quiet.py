"""``score4 -q COMMAND``: one switch that keeps every command's stderr to errors only.

Quiet means no progress bars, no notices ("Geant4 output: ...", "wrote ..." to stderr) and no
:class:`~score4.errors.Score4Warning`; results on stdout and errors are printed as always.
``score4 run -q`` and ``score4 range -q`` are the same switch given to one command.
"""

from __future__ import annotations

import warnings

import click

from ..errors import Score4Warning

_KEY = "score4.quiet"  # in Context.meta, which every nested context of one call shares


def set_quiet(ctx: click.Context) -> None:
    """Make the rest of this command line quiet (warnings filtered, :func:`notice` silent)."""
    ctx.meta[_KEY] = True
    warnings.simplefilter("ignore", Score4Warning)


def is_quiet() -> bool:
    """Whether ``score4 -q`` (or a command's own ``-q``) asked for quiet."""
    ctx = click.get_current_context(silent=True)
    return bool(ctx is not None and ctx.meta.get(_KEY))


def notice(message: str) -> None:
    """Progress or a notice on stderr, unless quiet."""
    if not is_quiet():
        click.echo(message, err=True)
