"""Turn a source configuration into :class:`Primaries` for a chunk of events."""

from __future__ import annotations

import numpy as np

from ..config import RunConfig
from .faces import box_face
from .primaries import Primaries


def isotropic_directions(rng: np.random.Generator, n: int) -> np.ndarray:
    """Unit vectors uniform on the sphere (uniform cos(theta) and phi)."""
    cos_t = rng.uniform(-1.0, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    sin_t = np.sqrt(1.0 - cos_t**2)
    return np.column_stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t])


def make_primaries(config: RunConfig, rng: np.random.Generator, n_events: int) -> Primaries:
    """One primary per event, uniform on the configured box face."""
    src = config.source
    target = config.target(src.surface.volume)
    face = box_face(target.position, target.size, src.surface.face)
    s, t = rng.uniform(size=(2, n_events))
    position = face.origin + s[:, None] * face.u + t[:, None] * face.v
    direction = isotropic_directions(rng, n_events)
    if src.direction == "normal":
        direction = np.tile(-face.normal, (n_events, 1))
    elif src.direction != "isotropic":
        # Fold into the wanted half-space: "inward" is against the face's outward normal.
        along = direction @ face.normal
        flip = along > 0 if src.direction == "inward" else along < 0
        direction[flip] -= 2.0 * along[flip, None] * face.normal
    return Primaries(
        event=np.arange(n_events),
        particle=np.full(n_events, src.particle),
        energy=np.full(n_events, src.energy),
        position=position,
        direction=direction,
    )
