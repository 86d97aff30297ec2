"""Shapes from plain data: :func:`shape_from_dict`, the inverse of ``Shape.to_dict()`` (the
volume model of a GDML world stores its solids so), and :data:`SHAPE_TYPES`, the dataclasses
by Geant4 type name."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigError
from .base import Shape
from .boolean import BooleanShape
from .csg import G4Box, G4Cons, G4Orb, G4Sphere, G4Trap, G4Trd, G4Tubs
from .mesh_shape import MeshShape
from .placed import PlacedShape
from .revolved import G4GenericPolycone, G4GenericPolyhedra, G4Polycone, G4Polyhedra
from .transform import Transform

#: The shape dataclasses by Geant4 type name (``G4Box``, ...).
SHAPE_TYPES: dict[str, Any] = {
    c.kind: c
    for c in (
        G4Box,
        G4Trd,
        G4Trap,
        G4Tubs,
        G4Cons,
        G4Sphere,
        G4Orb,
        G4Polycone,
        G4GenericPolycone,
        G4Polyhedra,
        G4GenericPolyhedra,
    )
}


def shape_from_dict(data: dict[str, Any]) -> Shape:
    """Inverse of ``shape.to_dict()``."""
    data = dict(data)
    kind = data.pop("type", None)
    if kind in SHAPE_TYPES:
        return SHAPE_TYPES[kind](**data)
    if kind == "MeshShape":
        return MeshShape(
            np.array(data["triangles"]),
            np.array(data["facet_faces"]),
            tuple(data["face_names"]),
            tuple((g, tuple(f)) for g, f in data.get("face_groups", [])),
        )
    if kind == "BooleanShape":
        return BooleanShape(
            data["operation"],
            shape_from_dict(data["first"]),
            shape_from_dict(data["second"]),
            Transform(**data["transform"]),
        )
    if kind == "PlacedShape":
        return PlacedShape(shape_from_dict(data["shape"]), Transform(**data["transform"]))
    raise ConfigError(
        f"shape: unknown type {kind!r}; known: {', '.join(SHAPE_TYPES)}, "
        "MeshShape, BooleanShape, PlacedShape"
    )
