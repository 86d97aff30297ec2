"""Contamination sources as numpy: vertices on rough surfaces, depth profiles, emitters.

Nothing in this package imports Geant4; the simulation layer turns :class:`Primaries` into
Geant4 primary vertices.
"""

from .primaries import Primaries

__all__ = ["Primaries"]
