"""Primary particles of a batch of events, as flat numpy arrays."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError


@dataclass
class Primaries:
    """Pre-sampled primary particles, one row per particle, several rows per event allowed.

    Parameters
    ----------
    event
        (n,) int64 event index of each particle, non-decreasing, starting at 0, with no gaps:
        rows ``event == k`` are the primaries of event ``k`` (e.g. a Po-210 alpha and its
        Pb-206 recoil share one event).
    particle
        (n,) str: Geant4 particle names ("alpha", "e-", "gamma") or ion names "Pb206",
        "Po210" (element symbol + mass number; excitation energy zero).
    energy
        (n,) kinetic energy in MeV.
    position
        (n, 3) vertex positions in mm (world coordinates).
    direction
        (n, 3) unit momentum directions.
    extra
        Per-row extra columns (n,) kept with the output, e.g. ``depth`` (mm), ``facet``,
        ``patch``.
    """

    event: np.ndarray
    particle: np.ndarray
    energy: np.ndarray
    position: np.ndarray
    direction: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.event = np.asarray(self.event, dtype=np.int64)
        self.particle = np.asarray(self.particle, dtype=str)
        self.energy = np.asarray(self.energy, dtype=float)
        self.position = np.asarray(self.position, dtype=float).reshape(-1, 3)
        self.direction = np.asarray(self.direction, dtype=float).reshape(-1, 3)
        n = len(self.event)
        for name in ("particle", "energy", "position", "direction"):
            if len(getattr(self, name)) != n:
                raise ConfigError(
                    f"primaries.{name}: has {len(getattr(self, name))} rows, event has {n}"
                )
        for name, col in self.extra.items():
            if len(col) != n:
                raise ConfigError(f"primaries.extra[{name!r}]: has {len(col)} rows, event has {n}")
        if n:
            steps = np.diff(self.event)
            if self.event[0] != 0 or (steps < 0).any() or (steps > 1).any():
                raise ConfigError(
                    "primaries.event: must start at 0 and increase by 0 or 1 from row to row"
                )
        if (self.energy < 0).any() or not np.isfinite(self.energy).all():
            raise ConfigError("primaries.energy: kinetic energies must be finite and >= 0")
        norms = np.linalg.norm(self.direction, axis=1)
        if n and not np.allclose(norms, 1.0, atol=1e-9):
            raise ConfigError("primaries.direction: every direction must be a unit vector")

    @property
    def n_events(self) -> int:
        """Number of events (the last event index + 1)."""
        return int(self.event[-1]) + 1 if len(self.event) else 0

    def __len__(self) -> int:
        return len(self.event)

    def event_offsets(self) -> np.ndarray:
        """(n_events + 1,) row offsets: rows of event k are ``offsets[k]:offsets[k+1]``."""
        return np.searchsorted(self.event, np.arange(self.n_events + 1), side="left")

    def select_events(self, start: int, stop: int) -> Primaries:
        """The events ``start <= k < stop``, renumbered from 0."""
        off = self.event_offsets()
        rows = slice(off[start], off[min(stop, self.n_events)])
        return Primaries(
            event=self.event[rows] - start,
            particle=self.particle[rows],
            energy=self.energy[rows],
            position=self.position[rows],
            direction=self.direction[rows],
            extra={k: v[rows] for k, v in self.extra.items()},
        )

    @classmethod
    def concatenate(cls, parts: list[Primaries]) -> Primaries:
        """Join batches, renumbering events so they follow each other."""
        shift, events = 0, []
        for p in parts:
            events.append(p.event + shift)
            shift += p.n_events
        keys = set(parts[0].extra) if parts else set()
        return cls(
            event=np.concatenate(events) if parts else np.zeros(0, np.int64),
            particle=np.concatenate([p.particle for p in parts]) if parts else np.zeros(0, str),
            energy=np.concatenate([p.energy for p in parts]) if parts else np.zeros(0),
            position=np.concatenate([p.position for p in parts]) if parts else np.zeros((0, 3)),
            direction=np.concatenate([p.direction for p in parts]) if parts else np.zeros((0, 3)),
            extra={k: np.concatenate([p.extra[k] for p in parts]) for k in keys},
        )


def atom_histories(primaries: Primaries) -> bool:
    """True for per-atom histories (a chain with implantation): rows carry ``atom`` and
    ``decay_index``, and the unit of a run is the atom, not the event."""
    return "atom" in primaries.extra and "decay_index" in primaries.extra
