"""Energy deposit per scoring volume per event, accumulated in C++.

Each scoring volume gets one G4MultiFunctionalDetector with a G4PSEnergyDeposit primitive,
shared by all of its logical volumes; Python reads one hits map per volume per event.
(benchmarks/bench_scoring.py compares this with a Python stepping action and a Python
sensitive detector.)
"""

from __future__ import annotations

import numpy as np


class EdepScorer:
    """Attach with :meth:`attach` in ConstructSDandField; read with :meth:`read` per event."""

    def __init__(self, g4, groups: dict[str, list]) -> None:
        self.g4 = g4
        self.names = list(groups)
        self.groups = groups
        self.detectors: list = []
        self.collection_ids: list[int] = []

    def attach(self) -> None:
        g4 = self.g4
        sdm = g4.G4SDManager.GetSDMpointer()
        sdm.SetVerboseLevel(0)
        for name in self.names:
            mfd = g4.G4MultiFunctionalDetector(f"score4_{name}")
            mfd.RegisterPrimitive(g4.G4PSEnergyDeposit("edep"))
            sdm.AddNewDetector(mfd)
            for lv in self.groups[name]:
                lv.SetSensitiveDetector(mfd)
            self.detectors.append(mfd)

    def resolve_ids(self) -> None:
        """Collection ids exist only after the run manager is initialised."""
        sdm = self.g4.G4SDManager.GetSDMpointer()
        self.collection_ids = [sdm.GetCollectionID(f"score4_{n}/edep") for n in self.names]

    def read(self, event, out: np.ndarray) -> None:
        """Write this event's deposit (MeV) per volume into ``out`` (one row)."""
        hce = event.GetHCofThisEvent()
        if hce is None:
            out[:] = 0.0
            return
        for k, cid in enumerate(self.collection_ids):
            out[k] = sum(value for _, value in hce.GetHC(cid))
