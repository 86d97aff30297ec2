"""The ``score4`` command line.

A Ctrl-C before :func:`score4.cli.main.main` handles it (while Python imports click, numpy,
pydantic in the first half second) ends the command with ``score4: aborted`` and status 130,
not a traceback: the ``score4`` console script and ``python -m score4`` set the hook below
before anything heavy is imported (a library user's process is left alone).
"""

from __future__ import annotations

import os
import sys


def _interrupted(kind, value, traceback) -> None:
    if issubclass(kind, KeyboardInterrupt):
        try:
            sys.stdout.flush()
            sys.stderr.write("\nscore4: aborted\n")
            sys.stderr.flush()
        finally:
            os._exit(130)
    sys.__excepthook__(kind, value, traceback)


def quiet_interrupts() -> None:
    """Print an uncaught Ctrl-C as ``score4: aborted`` (exit status 130), not as a traceback."""
    sys.excepthook = _interrupted


if sys.argv and os.path.basename(sys.argv[0]) == "score4":  # the console script
    quiet_interrupts()
