"""Per-event quantities per scoring volume, accumulated in C++.

Each scoring volume gets one G4MultiFunctionalDetector, shared by all of its logical
volumes, with a G4PSEnergyDeposit primitive (and optionally G4PSTrackLength); Python reads
one hits map per quantity per volume per event. (benchmarks/bench_scoring.py compares this
with a Python stepping action and a Python sensitive detector.)
"""

from __future__ import annotations

import numpy as np

# Quantity name -> Geant4 primitive scorer class name.
PRIMITIVES = {"edep": "G4PSEnergyDeposit", "track_length": "G4PSTrackLength"}


class VolumeScorer:
    """Attach with :meth:`attach` in ConstructSDandField; read with :meth:`read` per event."""

    def __init__(
        self, g4, groups: dict[str, list], quantities: tuple[str, ...] = ("edep",)
    ) -> None:
        self.g4 = g4
        self.names = list(groups)
        self.groups = groups
        self.quantities = quantities
        self.detectors: list = []
        self.collection_ids: list[list[int]] = []

    def attach(self) -> None:
        g4 = self.g4
        sdm = g4.G4SDManager.GetSDMpointer()
        sdm.SetVerboseLevel(0)
        for name in self.names:
            mfd = g4.G4MultiFunctionalDetector(f"score4_{name}")
            for q in self.quantities:
                mfd.RegisterPrimitive(getattr(g4, PRIMITIVES[q])(q))
            sdm.AddNewDetector(mfd)
            for lv in self.groups[name]:
                lv.SetSensitiveDetector(mfd)
            self.detectors.append(mfd)

    def resolve_ids(self) -> None:
        """Collection ids exist only after the run manager is initialised."""
        sdm = self.g4.G4SDManager.GetSDMpointer()
        self.collection_ids = [
            [sdm.GetCollectionID(f"score4_{n}/{q}") for n in self.names] for q in self.quantities
        ]

    def read(self, event, out: dict[str, np.ndarray], row: int) -> None:
        """Write this event's sums per volume into ``out[quantity][row]`` (MeV, mm)."""
        hce = event.GetHCofThisEvent()
        if hce is None:
            return
        for q, ids in zip(self.quantities, self.collection_ids, strict=True):
            target = out[q][row]
            for k, cid in enumerate(ids):
                target[k] = sum(value for _, value in hce.GetHC(cid))
