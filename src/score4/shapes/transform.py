"""Rigid transforms: local shape frame -> mother or world frame, ``x' = R x + t``."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError

_EYE = np.eye(3)


@dataclass(frozen=True, eq=False)
class Transform:
    """``apply(x) = rotation @ x + translation`` (active: the object is rotated, then moved).

    This is Geant4's object transform: for a placement, ``rotation`` is
    ``pv.GetObjectRotationValue()`` and ``translation`` is ``pv.GetTranslation()``; along a
    placement chain, compose ``mother_global * daughter_local``.
    """

    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        r = np.array(self.rotation, float).reshape(3, 3)
        # np.allclose(r @ r.T, I, atol=1e-9) written out: a transform is made for every face
        # frame, placement and box of a world, and allclose costs three times as much
        if not (np.abs(r @ r.T - _EYE) <= 1e-9 + 1e-5 * _EYE).all():
            raise ConfigError("transform: the rotation must be orthonormal")
        if np.linalg.det(r) < 0:
            raise ConfigError("transform: reflections are not supported (det(rotation) < 0)")
        object.__setattr__(self, "rotation", r)
        object.__setattr__(self, "translation", np.array(self.translation, float).reshape(3))

    @classmethod
    def from_g4(cls, rotation: Any, translation: Any) -> Transform:
        """From a G4RotationMatrix (object rotation, ``pv.GetObjectRotationValue()``; None for
        none) and a G4ThreeVector (``pv.GetTranslation()``), duck-typed."""
        r = (
            np.eye(3)
            if rotation is None
            else np.array(
                [
                    [rotation.xx, rotation.xy, rotation.xz],
                    [rotation.yx, rotation.yy, rotation.yz],
                    [rotation.zx, rotation.zy, rotation.zz],
                ],
                float,
            )
        )
        return cls(r, np.array([translation.x, translation.y, translation.z], float))

    def apply(self, points: ArrayLike) -> np.ndarray:
        return np.asarray(points, float) @ self.rotation.T + self.translation

    def apply_vectors(self, vectors: ArrayLike) -> np.ndarray:
        return np.asarray(vectors, float) @ self.rotation.T

    def inverse_apply(self, points: ArrayLike) -> np.ndarray:
        return (np.asarray(points, float) - self.translation) @ self.rotation

    def relative_to(self, frame: Transform) -> Transform:
        """This transform seen from ``frame``: ``frame.inverse() @ self``, so that
        ``frame.apply(t.relative_to(frame).apply(x)) == t.apply(x)`` (a world placement in the
        coordinates of its mother)."""
        return Transform(frame.rotation.T @ self.rotation, frame.inverse_apply(self.translation))

    def __matmul__(self, other: Transform) -> Transform:
        """``(self @ other).apply(x) == self.apply(other.apply(x))``."""
        return Transform(self.rotation @ other.rotation, self.apply(other.translation))

    def to_dict(self) -> dict[str, list]:
        return {"rotation": self.rotation.tolist(), "translation": self.translation.tolist()}
