"""Distances in a boolean solid (G4UnionSolid, G4SubtractionSolid, G4IntersectionSolid) with
rough layers on its faces, for steps (``dist_to_surf``) and activeness (numpy, no Geant4).

A boolean's signed distance combines its constituents' (:meth:`BooleanShape.signed_distance`:
the smaller of two for a union, the larger for an intersection, ``max(a, -b)`` for ``a`` less
``b``). A rough layer on a face of a *leaf* solid (:meth:`BooleanShape.face_clip`) changes only
that leaf: its distance becomes the smaller of the exact distance to its other faces
(:func:`score4.world.face_distance.face_distance`) and the distance to the layer's rough surface
(its patch tops where a cell is kept, the leaf's face where not:
:class:`score4.world.rough_distance.RoughSurfaceDistance`, or the curved one for a cylinder
wall or a bore), and a point in a patch is in the leaf (outside it for a subtracted leaf, whose
patches lie in the hole). The boolean combines the leaves as before (:func:`rough_signed`). The
cells that are not kept count as the leaf's flat face, so the boolean's own cut decides, as for
a smooth face, where that face is part of the surface. Where a face's one flat layer reaches
past the face (a square grid over a round floor), its flat cells there are not the leaf's face:
below the layer's level the rough surface's distance is raised to the face's own
(:func:`below_level`), exact beside the face's column.

Like the smooth boolean's, the result is a lower bound of the true distance to the surface,
exact where the nearest point of the nearest constituent's surface lies on the boolean's
surface (everywhere inside a box less a tube along an axis, or a cylinder with a cut).

The distance to some faces of a boolean (activeness ``faces``) is the larger of the distance to
the whole surface and the distance to the listed faces: a smooth face as it is on the boolean
(the part the other constituents keep, :class:`score4.world.kept_face_distance.KeptFaceDistance`:
exact to its ``TOLERANCE``), a rough face laid as flat layers by its patch tops and its flat
rest on the boolean's face (:class:`score4.world.rough_face_distance.FlatRoughFaceDistance`:
exact to the same ``TOLERANCE``), a curved rough face by its whole layer's rough surface, raised
below the layer's level to the distance to the face as it is on the boolean there
(:meth:`BooleanDistance._beside`: a lower bound, exact beside the face's column, off by at most
the patches' height over it where the layer's flat cells reach off the boolean's surface).

With ``into`` a rough face's layer lies on the cut face, so its rough surface is measured there;
the leaves and the other faces stay the uncut solid's, as on a plain solid with ``into``
(:class:`score4.world.activeness.TargetDistance`): the faces beside the cut reach into the slab
the layer lies in.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError
from ..shapes import BooleanShape, Shape
from ..shapes.placed import PlacedShape
from .face_distance import face_distance
from .kept_face_distance import KeptFaceDistance
from .rough_face_distance import FlatRoughFaceDistance

if TYPE_CHECKING:
    from .scene import RoughLayer, TargetVolume

#: A rough surface's distance: world points (n, 3) -> mm (n,)
Measure = Callable[[np.ndarray], np.ndarray]


@dataclass
class RoughLeaf:
    """A leaf solid of a boolean with rough layers: its faces that are rough (``faces``, leaf
    names), the distances to their rough surfaces and their layers (``measures``, ``layers``),
    and whether the boolean's outward normal is against the leaf's (``flipped``: a subtracted
    solid)."""

    leaf: Shape
    faces: list[str]
    measures: list[Measure]
    layers: list[RoughLayer]
    flipped: bool
    #: per rough face, its one flat layer (None: several, or curved), for :func:`below_level`
    levels: list[RoughLayer | None] = field(default_factory=list)

    def signed(self, local: np.ndarray, world: np.ndarray) -> np.ndarray:
        """The rough leaf's signed distance at points ``local`` (leaf frame; ``world``: the same
        points in the world) (< 0 inside)."""

        others = tuple(f for f in self.leaf.faces if f not in self.faces)
        d = face_distance(self.leaf, others, local) if others else np.full(len(local), np.inf)
        for measure, level in zip(self.measures, self.levels, strict=True):
            m = measure(world)
            if level is not None:
                below = level.frame.to_local(world)[:, 2] <= 0
                if below.any():
                    m[below] = np.maximum(m[below], below_level(level, world[below]))
            d = np.minimum(d, m)
        inside = self.leaf.signed_distance(local) <= 0
        in_patch = np.zeros(len(world), dtype=bool)
        for layer in self.layers:
            in_patch |= layer.contains(world)
        inside = inside & ~in_patch if self.flipped else inside | in_patch
        return np.where(inside, -d, d)


def below_level(layer: RoughLayer, world: np.ndarray) -> np.ndarray:
    """Distance of world points to the face of the leaf the flat ``layer`` lies on, at the
    layer's level (the leaf cut behind it with ``into``), whole: at points below that level no
    point of the layer's rough surface on the leaf is nearer (its patches and flat rest lie over
    that face, at or above the level), so the rough surface's distance is raised to it there;
    exact beside the face's column, where the layer's flat cells reach past the face."""
    on = layer.on_boolean
    assert on is not None
    clip = on.clip
    local = clip.transform.inverse_apply(on.transform.inverse_apply(world))
    return face_distance(clip.leaf, (clip.face,), local)


def leaf_path(shape: BooleanShape, face: str) -> tuple[str, str]:
    """(path of the leaf, its face name) of boolean face ``face``: ``first.second.outer`` is face
    ``outer`` of the leaf at ``first.second.``."""
    clip = shape.face_clip(face)
    return face[: len(face) - len(clip.face)], clip.face


def rough_signed(
    shape: Shape, local: np.ndarray, world: np.ndarray, leaves: dict[str, RoughLeaf], path: str = ""
) -> np.ndarray:
    """The signed distance of ``shape`` at ``local`` (its frame; ``world``: the same points in
    the world) with the leaves in ``leaves`` (by path) rough."""
    while isinstance(shape, PlacedShape):
        local, shape = shape.transform.inverse_apply(local), shape.shape
    if isinstance(shape, BooleanShape):
        a = rough_signed(shape.first, local, world, leaves, path + "first.")
        second = shape.transform.inverse_apply(local)
        b = rough_signed(shape.second, second, world, leaves, path + "second.")
        if shape.operation == "union":
            return np.minimum(a, b)
        if shape.operation == "intersection":
            return np.maximum(a, b)
        return np.maximum(a, -b)
    if path in leaves:
        return leaves[path].signed(local, world)
    return shape.signed_distance(local)


def leaf_face_distance(
    shape: BooleanShape, faces: tuple[str, ...], local: np.ndarray
) -> np.ndarray:
    """Exact distance of points (the boolean's frame) to the listed faces of the boolean's
    constituents, each face whole (where it is cut too: a lower bound of the distance to the
    boolean's faces)."""

    best = np.full(len(local), np.inf)
    for name in faces:
        clip = shape.face_clip(name)
        best = np.minimum(
            best, face_distance(clip.leaf, (clip.face,), clip.transform.inverse_apply(local))
        )
    return best


class BooleanDistance:
    """Distances of world points to the surface of a ``target`` whose solid is a boolean, with
    its rough ``layers`` (boolean face name -> its layers: one per plane of a face of several)
    measured by ``measure(face)``."""

    def __init__(
        self,
        target: TargetVolume,
        layers: dict[str, list[RoughLayer]],
        measure: Callable[[str], Measure],
    ) -> None:
        shape = target.shape
        assert isinstance(shape, BooleanShape)
        self.target, self.shape = target, shape
        self._kept: dict[tuple[str, ...], KeptFaceDistance] = {}
        self._layers = layers
        self._level: dict[str, KeptFaceDistance] = {}
        self._flat: dict[str, FlatRoughFaceDistance] = {}
        self.leaves: dict[str, RoughLeaf] = {}
        for face, on_face in layers.items():
            path, leaf_face = leaf_path(shape, face)
            clip = shape.face_clip(face)
            leaf = self.leaves.setdefault(path, RoughLeaf(clip.leaf, [], [], [], clip.flipped))
            leaf.faces.append(leaf_face)
            leaf.measures.append(_lazy(measure, face))
            leaf.layers.extend(on_face)
            flat = len(on_face) == 1 and not on_face[0].curved
            leaf.levels.append(on_face[0] if flat else None)

    def signed(self, world: np.ndarray) -> np.ndarray:
        """Signed distance (mm, < 0 inside the volume or its patches) of world points."""
        world = np.asarray(world, float).reshape(-1, 3)
        local = self.target.to_local(world)
        if not self.leaves:
            return self.shape.signed_distance(local)
        return rough_signed(self.shape, local, world, self.leaves)

    def to_surface(self, world: np.ndarray) -> np.ndarray:
        """Distance (mm) of world points to the whole surface (0 outside)."""
        return np.maximum(-self.signed(world), 0.0)

    def to_faces(
        self, faces: tuple[str, ...], world: np.ndarray, rough: Callable[[str], Measure]
    ) -> np.ndarray:
        """Distance (mm) of world points to the listed faces (0 outside): the larger of the
        distance to the whole surface and that to the listed faces (smooth ones as they are on
        the boolean, rough ones by their rough surface)."""
        world = np.asarray(world, float).reshape(-1, 3)
        whole = self.to_surface(world)
        if set(faces) >= set(self.shape.faces):
            return whole
        local = self.target.to_local(world)
        smooth = tuple(f for f in faces if f not in self._rough_faces)
        d = self.kept_faces(smooth)(local) if smooth else np.full(len(world), np.inf)
        for f in faces:
            if f in self._rough_faces:
                d = np.minimum(d, self.rough_face(f, world, local, rough))
        return np.where(whole > 0, np.maximum(whole, d), 0.0)

    def rough_face(
        self, face: str, world: np.ndarray, local: np.ndarray, rough: Callable[[str], Measure]
    ) -> np.ndarray:
        """Distance of world points (``local``: the target's frame) to the rough ``face`` as it
        is on the boolean: exact for flat layers (one, or one per plane: patch tops and the flat
        rest on the face, :class:`FlatRoughFaceDistance`); for a curved layer the whole layer's
        rough surface raised as :meth:`_beside` says (a lower bound)."""
        layers = self._layers[face]
        if not any(layer.curved for layer in layers):
            if face not in self._flat:
                self._flat[face] = FlatRoughFaceDistance(layers)
            return self._flat[face](world)
        return self._beside(face, world, local, rough(face)(world))

    def _beside(self, face: str, world: np.ndarray, local: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The distance ``d`` to the rough ``face`` (its whole layer's rough surface, the flat
        cells off the boolean included) raised, at points below the layer's level, to the
        distance to the face as it is on the boolean at that level (the cut face with ``into``):
        the layer's patches and flat rest lie over that face, at or above its level, so no point
        of the rough surface is nearer. Exact beside the face's column; over it, off by at most
        the patches' height where a flat cell off the boolean is nearer than a patch. A face of
        several planes or a curved one keeps ``d``."""
        layers = self._layers[face]
        layer = layers[0]
        if len(layers) != 1 or layer.curved:
            return d
        below = layer.frame.to_local(world)[:, 2] <= 0
        if not below.any():
            return d
        if face not in self._level:  # the layer's boolean: cut behind the face for into
            on = layer.on_boolean
            assert on is not None
            assert isinstance(on.shape, BooleanShape)
            self._level[face] = KeptFaceDistance(on.shape, (face,))
        out = d.copy()
        out[below] = np.maximum(d[below], self._level[face](local[below]))
        return out

    def kept_faces(self, faces: tuple[str, ...]) -> KeptFaceDistance:
        """The exact distance to the smooth ``faces`` as they are on the boolean (built once per
        face list: their rims)."""
        if faces not in self._kept:
            self._kept[faces] = KeptFaceDistance(self.shape, faces)
        return self._kept[faces]

    @property
    def _rough_faces(self) -> set[str]:
        return {path + face for path, leaf in self.leaves.items() for face in leaf.faces}


def _lazy(measure: Callable[[str], Measure], face: str) -> Measure:
    return lambda world: measure(face)(world)


def check_measurable(layer: RoughLayer, where: str) -> None:
    """Steps and activeness on the rough ``layer`` of a boolean face need the exact distance to
    its leaf's other faces: a one-line error where :func:`face_distance` cannot give it."""

    on = layer.on_boolean
    assert on is not None
    leaf, face = on.clip.leaf, on.clip.face
    others = tuple(f for f in leaf.faces if f != face)
    try:
        if others:
            face_distance(leaf, others, np.zeros((1, 3)))
    except ConfigError as err:
        raise ConfigError(
            f"{where}: steps (output.steps) and activeness need the distance to the other faces "
            f"of the {leaf.kind} whose face {face} is rough: "
            f"{str(err).removeprefix('activeness: ')}"
        ) from None
