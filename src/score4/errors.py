"""Exceptions raised by score4.

Every error a user can cause by bad input is a :class:`Score4Error`; its message names the
parameter, the value and the rule, in one line, so the CLI can print it as it is.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator


def brief(value: object, limit: int = 60) -> str:
    """``repr(value)`` cut to about ``limit`` characters: messages never repeat unbounded input.

    Containers are not expanded beyond what the cut keeps (a YAML alias bomb expands to 10^9
    items; its repr would never finish).
    """
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 100:
        return f"{'-' if value < 0 else ''}a {int(value.bit_length() * 0.30103) + 1}-digit number"
    if isinstance(value, (dict, list, tuple, set)):
        kind = type(value).__name__
        if len(value) > 8:
            return f"<{kind} of {len(value)} items>"
        try:
            text = _short_repr(value)
        except RecursionError:
            return f"<{kind}>"
    else:
        text = repr(value[: 2 * limit] if isinstance(value, (str, bytes)) else value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _short_repr(value: object) -> str:
    """repr with nested containers and long strings shortened (reprlib), never unbounded."""
    import reprlib

    r = reprlib.Repr()
    r.maxlevel, r.maxstring, r.maxother, r.maxdict, r.maxlist = 3, 40, 40, 6, 6
    return r.repr(value)


class Score4Error(Exception):
    """Base class for errors caused by input (configuration, files, data sets)."""


class ConfigError(Score4Error, ValueError):
    """A configuration value is invalid."""


class DataError(Score4Error):
    """Geant4 data sets are missing, corrupt or cannot be installed."""


class PhysicsUnavailableError(Score4Error):
    """The requested physics needs data sets that are not installed."""


class RunCancelled(Score4Error):
    """A Geant4 run stopped half-way because its caller asked (a cancelled Dask chunk)."""


class Score4Warning(UserWarning):
    """Something score4 did on its own that the user should know (input normalised, lite physics).

    The command line prints each as one line ``score4: warning: <message>``, once, and not at
    all with ``--quiet``.
    """


class RunInterrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C or SIGTERM; the message says what was kept and how to resume."""


@contextlib.contextmanager
def naming_file(path: object) -> Iterator[None]:
    """Prefix ``<path>: `` to configuration errors raised inside that do not name a file yet.

    Errors found after validation (materials, depth tables, surfaces, geometry, particles) come
    from code that sees the validated objects, not the file they came from; the command line
    wraps its work in this so that every such error names the configuration file. Errors about
    command-line options (``--out: ...``) and errors that already start with the path are left
    as they are.
    """
    try:
        yield
    except ConfigError as err:
        text, name = str(err), str(path)
        if text.startswith((name, "--")):
            raise
        raise type(err)(f"{name}: {text}") from None
