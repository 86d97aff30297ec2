"""Rough surfaces as pure numpy: height maps, spike grids, random fields, readers, meshes,
metrology.

Nothing in this package imports Geant4.
"""

from .fit import fit_random_surface
from .heightmap import HeightMap
from .metrology import PARAMETERS, areal_parameters, mesh_parameters
from .processing import crop, fill_missing, level_plane, resample
from .random import random_surface
from .readers import read_topography
from .spikes import SpikeGrid
from .triangle_mesh import TriangleMesh, closed_body, from_heightmap

__all__ = [
    "PARAMETERS",
    "HeightMap",
    "SpikeGrid",
    "TriangleMesh",
    "areal_parameters",
    "closed_body",
    "crop",
    "fill_missing",
    "fit_random_surface",
    "from_heightmap",
    "level_plane",
    "mesh_parameters",
    "random_surface",
    "read_topography",
    "resample",
]
