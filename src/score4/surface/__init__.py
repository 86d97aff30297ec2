"""Rough surfaces as pure numpy: height maps, spike grids, random fields, readers, meshes, metrology.

Nothing in this package imports Geant4.
"""

from .heightmap import HeightMap
from .mesh import TriangleMesh, closed_body, from_heightmap
from .metrology import PARAMETERS, areal_parameters, mesh_parameters
from .spikes import SpikeGrid

__all__ = [
    "HeightMap",
    "TriangleMesh",
    "closed_body",
    "from_heightmap",
    "SpikeGrid",
    "PARAMETERS",
    "areal_parameters",
    "mesh_parameters",
]
