"""A shape moved by a rigid transform (G4DisplacedSolid; a volume placed in the world)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .base import Shape, ShapeSample, as_points
from .transform import Transform


@dataclass(frozen=True, eq=False)
class PlacedShape(Shape):
    """``shape`` seen through ``transform`` (points and normals mapped, same faces and areas)."""

    shape: Shape
    transform: Transform
    kind = "PlacedShape"

    @property
    def faces(self) -> tuple[str, ...]:
        return self.shape.faces

    @property
    def groups(self) -> dict[str, tuple[str, ...]]:
        return self.shape.groups

    @property
    def face_areas(self) -> Mapping[str, float]:
        return self.shape.face_areas

    def face_sampler(self, faces: str | Sequence[str] = "all") -> PlacedFaceSampler:  # type: ignore[override]
        return PlacedFaceSampler(self.shape.face_sampler(faces), self.transform)

    def signed_distance(self, points: ArrayLike) -> np.ndarray:
        return self.shape.signed_distance(self.transform.inverse_apply(as_points(points)))

    @property
    def volume(self) -> float:
        return self.shape.volume

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.shape.bounding_box()
        corners = np.array(
            [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        c = self.transform.apply(corners)
        return c.min(axis=0), c.max(axis=0)

    def sample_volume(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return self.transform.apply(self.shape.sample_volume(rng, n))

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.kind,
            "shape": self.shape.to_dict(),
            "transform": self.transform.to_dict(),
        }


class PlacedFaceSampler:
    """A face sampler whose points and normals are mapped by a transform."""

    def __init__(self, inner: Any, transform: Transform) -> None:
        self.inner, self.transform = inner, transform
        self.area = inner.area
        self.faces = inner.faces
        self.planar = inner.planar

    def sample(self, rng: np.random.Generator, n: int) -> ShapeSample:
        s = self.inner.sample(rng, n)
        return ShapeSample(
            self.transform.apply(s.position), self.transform.apply_vectors(s.normal), s.face
        )
