"""score4: radioactive contamination on and below rough surfaces, simulated with Geant4."""

import os as _os
import sys as _sys

if _sys.argv and _os.path.basename(_sys.argv[0]) == "score4":
    # the console script: a Ctrl-C while the command imports is one line, not a traceback
    from .cli import quiet_interrupts as _quiet

    _quiet()

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("score4")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
