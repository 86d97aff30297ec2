"""Rough surfaces as pure numpy: height maps, spike grids, random fields, readers, meshes, metrology.

Nothing in this package imports Geant4.
"""

from .heightmap import HeightMap
from .mesh import TriangleMesh, closed_body, from_heightmap
from .metrology import PARAMETERS, areal_parameters, mesh_parameters
from .fit import fit_random_surface
from .processing import crop, fill_missing, level_plane, resample
from .random import random_surface
from .readers import read_topography
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
    "random_surface",
    "fit_random_surface",
    "read_topography",
    "level_plane",
    "crop",
    "resample",
    "fill_missing",
]
