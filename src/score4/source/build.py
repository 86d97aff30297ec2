"""Turn a source configuration into :class:`Primaries` for a chunk of events."""

from __future__ import annotations

import numpy as np

from ..config import RunConfig
from .emitters import isotropic_directions
from .faces import box_face
from .primaries import Primaries


def config_primaries(config: RunConfig, rng: np.random.Generator, n_events: int) -> Primaries:
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
