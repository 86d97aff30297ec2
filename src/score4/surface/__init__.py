"""Rough surfaces as pure numpy: height maps, spike grids, random fields, readers, meshes, metrology.

Nothing in this package imports Geant4.
"""

from .heightmap import HeightMap

__all__ = ["HeightMap"]
