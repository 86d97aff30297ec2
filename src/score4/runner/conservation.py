"""Energy conservation check of a run: no event may deposit more than its primaries brought.

An event's total energy deposit (all scoring volumes) can never exceed the kinetic energy of
its primaries, unless radioactive decay releases more (then the check does not apply). A
violation means a fault of the transport: Geant4 11.4's ``G4NuclearStopping`` caps its loss at
the pre-step energy instead of the energy left after ionisation, so a long step of a slow ion
deposits up to its ionisation loss twice (see ``benchmarks/bench_energy_conservation.py``).
The check runs in numpy on the finished chunk files, so it costs nothing per event.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

# An event violates conservation when it deposits more than this above its primaries' energy.
TOLERANCE_MEV = 1e-6  # 1 eV


@dataclass(frozen=True)
class EnergyBalance:
    """Events checked, events above their primaries' energy + tolerance, largest excess (MeV)."""

    events: int
    violations: int
    max_excess_mev: float

    def __add__(self, other: EnergyBalance) -> EnergyBalance:
        return EnergyBalance(
            self.events + other.events,
            self.violations + other.violations,
            max(self.max_excess_mev, other.max_excess_mev),
        )

    @property
    def warning(self) -> str | None:
        """One line for the user when some event broke energy conservation, else ``None``."""
        if not self.violations:
            return None
        return (
            f"energy conservation: {self.violations} of {self.events} events deposit more than "
            "their primaries' kinetic energy + 1 eV (largest excess "
            f"{self.max_excess_mev * 1e3:.4g} keV); counted in the run record (energy_violations)"
        )


def energy_balance(primary_energy: np.ndarray, edep: np.ndarray) -> EnergyBalance:
    """Check events given their primaries' total energy ``(n,)`` and deposits ``(n, volumes)``
    (MeV)."""
    primary_energy = np.asarray(primary_energy, dtype=float)
    edep = np.asarray(edep, dtype=float).reshape(len(primary_energy), -1)
    excess = edep.sum(axis=1) - primary_energy
    bad = excess > TOLERANCE_MEV
    return EnergyBalance(
        len(primary_energy),
        int(np.count_nonzero(bad)),
        float(excess[bad].max()) if bad.any() else 0.0,
    )


def check_chunk_files(paths: Iterable[Path]) -> EnergyBalance:
    """The energy balance of a run from its chunk files (``events/primary_energy`` and
    ``events/edep``)."""
    total = EnergyBalance(0, 0, 0.0)
    for path in paths:
        with h5py.File(path, "r") as f:
            edep = f["events/edep"]
            deposits = np.column_stack([edep[name][()] for name in edep])
            total = total + energy_balance(f["events/primary_energy"][()], deposits)
    return total
