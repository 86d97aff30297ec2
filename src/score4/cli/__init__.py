"""The ``score4`` command line.

A Ctrl-C before :func:`score4.cli.main.main` handles it (while Python imports click, numpy,
pydantic in the first half second) ends the command with ``score4: aborted`` and status 130,
not a traceback: the ``score4`` console script and ``python -m score4`` set the hook below
before anything heavy is imported (a library user's process is left alone).
"""

from __future__ import annotations

import _thread
import os
import sys
import threading


def _interrupted(kind, value, traceback) -> None:
    if issubclass(kind, KeyboardInterrupt):
        try:
            sys.stdout.flush()
            sys.stderr.write("\nscore4: aborted\n")
            sys.stderr.flush()
        finally:
            os._exit(130)
    sys.__excepthook__(kind, value, traceback)


def _swallowed(unraisable) -> None:
    # A Ctrl-C that lands in Python code called back from a C extension (pydantic-core building
    # a model's validator) is only printed there as "Exception ignored", and the command would
    # go on as if never interrupted: deliver it again, to the next line of plain Python.
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        # From another thread a moment later: raised in this hook, it would be lost again.
        threading.Timer(0.01, _thread.interrupt_main).start()
        return
    sys.__unraisablehook__(unraisable)


def quiet_interrupts() -> None:
    """Print an uncaught Ctrl-C as ``score4: aborted`` (exit status 130), not as a traceback,
    and never lose one inside a C extension."""
    sys.excepthook = _interrupted
    sys.unraisablehook = _swallowed


if sys.argv and os.path.basename(sys.argv[0]) == "score4":  # the console script
    quiet_interrupts()
