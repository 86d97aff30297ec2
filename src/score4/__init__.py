"""score4: radioactive contamination on and below rough surfaces, simulated with Geant4."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("score4")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
