"""Geant4 solids in numpy: named faces, exact areas and volumes, inside, area-uniform sampling.

Pure numpy (never imports Geant4). Shapes are frozen dataclasses holding Geant4's own
parameters (mm, rad, half-lengths as Geant4 stores them); :func:`shape_from_dict` makes them
from plain data, :func:`score4.geometry.solid_shapes.shape_from_g4_solid` (worker side) from a
live Geant4 solid.
"""

from __future__ import annotations

from .base import INSIDE, OUTSIDE, SURFACE, FaceSampler, Shape, ShapeSample
from .boolean import BooleanShape
from .csg import G4Box, G4Cons, G4Orb, G4Sphere, G4Trap, G4Trd, G4Tubs
from .from_data import shape_from_dict
from .mesh_shape import MeshShape
from .placed import PlacedShape
from .revolved import G4GenericPolycone, G4GenericPolyhedra, G4Polycone, G4Polyhedra
from .transform import Transform

__all__ = [
    "INSIDE",
    "OUTSIDE",
    "SURFACE",
    "BooleanShape",
    "FaceSampler",
    "G4Box",
    "G4Cons",
    "G4GenericPolycone",
    "G4GenericPolyhedra",
    "G4Orb",
    "G4Polycone",
    "G4Polyhedra",
    "G4Sphere",
    "G4Trap",
    "G4Trd",
    "G4Tubs",
    "MeshShape",
    "PlacedShape",
    "Shape",
    "ShapeSample",
    "Transform",
    "shape_from_dict",
]
