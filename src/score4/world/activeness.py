"""Detector activeness: how much of a deposit counts, by its distance to the detector's faces.

LEGEND's piecewise-linear model (``targets[].activeness``): at distance ``d`` from the nearest
listed face a deposit counts with

    0                          for d < dlf * fccd     (dead layer)
    (d - dlf fccd) / ((1 - dlf) fccd)   up to d = fccd  (transition layer)
    1                          beyond                 (full charge collection)

Distances are exact, to the faces of the target's shape (:mod:`score4.shapes`): plane
triangles, surfaces of revolution (cylinders, cones, annuli, the contour of a polycone).
Several entries (each face its own fccd and dlf) combine by the smallest weight, which is the
nearest face's when the layers do not overlap.

A face with a flat rough layer is measured by its rough surface (the patch tops,
:mod:`score4.world.rough_distance`), for steps in the bulk under it and in its patches alike.
A face with a curved rough layer (patches bent onto a cylinder, cone or polycone segment) is
measured by its bent patch tops the same way (:class:`CurvedRoughSurfaceDistance`).
A boolean solid is measured through its constituents (:mod:`score4.world.boolean_distance`),
with its rough faces the same way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError
from ..shapes.base import Shape
from ..shapes.boolean import BooleanShape
from .boolean_distance import BooleanDistance, Measure, leaf_face_distance
from .face_distance import face_distance
from .rough_distance import CurvedRoughSurfaceDistance, RoughSurfaceDistance

if TYPE_CHECKING:  # world.scene imports this module when it needs activeness
    from .scene import RoughLayer, Scene, TargetVolume


def weight(d: np.ndarray, fccd: float, dlf: float) -> np.ndarray:
    """The piecewise-linear activeness at distances ``d`` (mm)."""
    d = np.asarray(d, float)
    dead = dlf * fccd
    if fccd <= dead:  # dlf = 1: a step function
        return (d >= fccd).astype(float)
    return np.clip((d - dead) / (fccd - dead), 0.0, 1.0)


class TargetDistance:
    """Distances of world points to faces of one target: plane faces and surfaces of revolution
    exactly (:func:`face_distance`), faces with a rough layer (flat or curved) to their rough
    surface.

    ``layers``: the target's rough layers (:class:`score4.world.scene.RoughLayer`)."""

    def __init__(self, target: TargetVolume, layers: list[RoughLayer]) -> None:
        self.target = target
        assert target.shape is not None  # target_distances gives None for such a volume
        self.shape: Shape = target.shape
        self.layers = list(layers)
        #: face name -> its rough layers (distances built on first use): one, or one per plane
        #: of a face of several planes (a subtracted G4Polyhedra's sides)
        self.rough: dict[str, list[RoughLayer]] = {}
        for layer in self.layers:
            (face,) = self.shape.resolve_faces([layer.config.face_name])
            self.rough.setdefault(face, []).append(layer)
        self._measures: dict[str, Measure] = {}
        try:  # every face measurable by face_distance (else the whole surface: signed distance)
            face_distance(self.shape, tuple(self.shape.faces), np.zeros((1, 3)))
            self.exact_faces = True
        except ConfigError:
            self.exact_faces = False
        #: a boolean solid: measured through its constituents
        self.boolean = (
            BooleanDistance(target, self.rough, self.rough_distance)
            if isinstance(self.shape, BooleanShape)
            else None
        )

    def rough_distance(self, face: str) -> Measure:
        """The distance to the rough surface of ``face`` (a face with a rough layer; of several
        planes, each with its layer: the nearest of them)."""
        if face not in self._measures:
            measures: list[Measure] = [
                CurvedRoughSurfaceDistance(layer)  # type: ignore[arg-type]
                if layer.curved
                else RoughSurfaceDistance(layer)
                for layer in self.rough[face]
            ]
            self._measures[face] = measures[0] if len(measures) == 1 else _nearest(measures)
        return self._measures[face]

    def _outside(self, world: np.ndarray, local: np.ndarray) -> np.ndarray:
        """Points outside the smooth shape and in none of its layers' patches (a hair outside
        the volume)."""
        outside = self.shape.signed_distance(local) > 1e-9
        rows = np.flatnonzero(outside)
        if len(rows):
            for layer in self.layers:
                outside[rows[layer.contains(world[rows])]] = False
        return outside

    def to_faces(self, faces: tuple[str, ...], world: np.ndarray) -> np.ndarray:
        """Distance (mm) of world points to the union of ``faces`` (0 where :meth:`_outside`)."""
        world = np.asarray(world, float).reshape(-1, 3)
        if self.boolean is not None:
            return self.boolean.to_faces(faces, world)
        local = self.target.to_local(world)
        flat = tuple(f for f in faces if f not in self.rough)
        d = face_distance(self.shape, flat, local) if flat else np.full(len(world), np.inf)
        for f in faces:
            if f in self.rough:
                d = np.minimum(d, self.rough_distance(f)(world))
        d[self._outside(world, local)] = 0.0
        return d

    def to_surface(self, world: np.ndarray) -> np.ndarray:
        """Distance (mm) of world points to the whole surface of the volume (its rough faces
        by their rough surface; 0 where :meth:`_outside`)."""
        world = np.asarray(world, float).reshape(-1, 3)
        if self.boolean is not None:
            return self.boolean.to_surface(world)
        if not self.rough or not self.exact_faces:
            return np.maximum(-self.shape.signed_distance(self.target.to_local(world)), 0.0)
        return self.to_faces(tuple(self.shape.faces), world)


def _nearest(measures: list[Measure]) -> Measure:
    """The smallest of several distances (the layers on the planes of one face)."""
    return lambda world: np.min([m(world) for m in measures], axis=0)


@dataclass
class VolumeActiveness:
    """The activeness entries of one scored volume: (faces, fccd mm, dlf) each, measured by
    ``distance``."""

    distance: TargetDistance
    entries: list[tuple[tuple[str, ...], float, float]]

    def weights(self, points: np.ndarray) -> np.ndarray:
        """The activeness at world ``points``."""
        p = np.asarray(points, float).reshape(-1, 3)
        w = np.ones(len(p))
        if not len(p):
            return w
        for faces, fccd, dlf in self.entries:
            w = np.minimum(w, weight(self.distance.to_faces(faces, p), fccd, dlf))
        return w


def _layers_of(scene: Scene, t: TargetVolume) -> list[RoughLayer]:
    """The rough layers of target ``t`` (a boolean's are laid out on its constituent, whose
    target is a copy of ``t``)."""
    return [
        r
        for r in scene.layers
        if r.target is t or (r.on_boolean is not None and r.target.column == t.column)
    ]


def target_distances(scene: Scene) -> list[TargetDistance | None]:
    """Per scoring column of ``scene``, the distances to its volume's faces (None: a solid
    :mod:`score4.shapes` does not describe)."""
    return [
        None if t.shape is None else TargetDistance(t, _layers_of(scene, t)) for t in scene.targets
    ]


def volume_activeness(
    scene: Scene, distances: list[TargetDistance | None] | None = None
) -> list[VolumeActiveness | None]:
    """Per scoring column of ``scene``, its activeness (None: every deposit counts).

    Bad input (faces the shape lacks, a shape score4 cannot measure) is refused here, with the
    parameter's path."""
    out: list[VolumeActiveness | None] = []
    for c, t in enumerate(scene.targets):
        entries = t.config.activeness
        if not entries:
            out.append(None)
            continue
        shape = t.shape
        if shape is None:
            raise ConfigError(
                f"targets.{t.entry}.activeness: {t.name}'s solid ({t.solid}) has no shape score4 "
                "can measure distances in"
            )
        resolved = []
        for j, a in enumerate(entries):
            where = f"targets.{t.entry}.activeness.{j}.faces"
            try:
                faces = shape.resolve_faces(a.faces)
            except ConfigError as err:
                raise ConfigError(f"{where}: {err}".replace(": face: ", ": ", 1)) from None
            resolved.append((faces, float(a.fccd), float(a.dlf)))
        for faces, _, _ in resolved:  # every face kind measurable: refuse now, not mid-run
            if isinstance(shape, BooleanShape):  # the whole surface needs no face distance
                if not set(faces) >= set(shape.faces):
                    leaf_face_distance(shape, faces, np.zeros((1, 3)))
            else:
                face_distance(shape, faces, np.zeros((1, 3)))
        distance = distances[c] if distances is not None else None
        if distance is None:
            distance = TargetDistance(t, _layers_of(scene, t))
        out.append(VolumeActiveness(distance, resolved))
    return out
