"""Contamination sources as numpy: vertices on rough surfaces, depth profiles, emitters.

Nothing in this package imports Geant4; the simulation layer turns :class:`Primaries` into
Geant4 primary vertices.
"""

from .depth import VertexSampler, Vertices
from .emitters import NuclideEmitter, ParticleEmitter, Po210Emitter, make_primaries
from .primaries import Primaries
from .profiles import (
    ExponentialProfile,
    MultiExponentialProfile,
    TableProfile,
    TruncatedGaussianProfile,
    UniformProfile,
    ZeroDepth,
)
from .sampling import SurfaceSampler, TiledSurfaceSampler

__all__ = [
    "ExponentialProfile",
    "MultiExponentialProfile",
    "NuclideEmitter",
    "ParticleEmitter",
    "Po210Emitter",
    "Primaries",
    "SurfaceSampler",
    "TableProfile",
    "TiledSurfaceSampler",
    "TruncatedGaussianProfile",
    "UniformProfile",
    "VertexSampler",
    "Vertices",
    "ZeroDepth",
    "make_primaries",
]
