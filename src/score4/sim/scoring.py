"""Per-event quantities per scoring volume, accumulated in C++.

Each scoring volume gets one G4MultiFunctionalDetector, shared by all of its logical
volumes, with a G4PSEnergyDeposit primitive (and optionally G4PSTrackLength); Python reads
one hits map per quantity per volume per event, after the BeamOn: Geant4 keeps the events
(:meth:`VolumeScorer.read_events`), so no Python runs at the end of each event. (benchmarks/
bench_scoring.py compares this with a Python stepping action and a Python sensitive detector.)
"""

from __future__ import annotations

import numpy as np

# Quantity name -> Geant4 primitive scorer class name.
PRIMITIVES = {
    "edep": "G4PSEnergyDeposit",
    "track_length": "G4PSTrackLength",
    "edep_alpha": "G4PSEnergyDeposit",
    "edep_electron": "G4PSEnergyDeposit",
}
#: Particle classes of the split deposits (``output.split_by_particle``), as G4SDParticleFilter
#: lists: a step's deposit counts for the class of the particle that made the step. The third
#: class, ``edep_ion`` (nuclei heavier than helium: recoils; and anything that is neither), is
#: the rest: ``edep - edep_alpha - edep_electron`` (:func:`ion_deposits`).
PARTICLE_FILTERS = {"edep_alpha": ("alpha",), "edep_electron": ("e-", "e+", "gamma")}
SPLIT_QUANTITIES = ("edep_alpha", "edep_electron")
#: Deposits below this (MeV) left over by the subtraction are rounding, not ions.
ION_ROUNDING = 1e-12


def ion_deposits(scores: dict[str, np.ndarray]) -> np.ndarray:
    """The ion class of split deposits: total minus alpha minus electron, rounding set to 0."""
    rest = scores["edep"] - scores["edep_alpha"] - scores["edep_electron"]
    rest[np.abs(rest) <= ION_ROUNDING * (1.0 + scores["edep"])] = 0.0
    return np.maximum(rest, 0.0)


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
        self.filters: list = []  # Geant4 keeps pointers only: Python must keep them alive
        self.collection_ids: list[list[int]] = []

    def attach(self) -> None:
        g4 = self.g4
        sdm = g4.G4SDManager.GetSDMpointer()
        sdm.SetVerboseLevel(0)
        for name in self.names:
            mfd = g4.G4MultiFunctionalDetector(f"score4_{name}")
            for q in self.quantities:
                primitive = getattr(g4, PRIMITIVES[q])(q)
                if q in PARTICLE_FILTERS:
                    particle_filter = g4.G4SDParticleFilter(f"score4_{name}_{q}")
                    for particle in PARTICLE_FILTERS[q]:
                        particle_filter.add(particle)
                    primitive.SetFilter(particle_filter)
                    self.filters.append(particle_filter)
                mfd.RegisterPrimitive(primitive)
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

    def read_events(self, events, out: dict[str, np.ndarray], first: int) -> None:
        """:meth:`read` of each G4Event of ``events`` (kept by Geant4 until its BeamOn ended)
        into rows ``first, first + 1, ..``. Read together after the BeamOn, a hits map costs a
        few microseconds; read by an event action between events, where Geant4's tracking has
        left the binding's code and data out of the caches, several times that."""
        read = self.read
        for row, event in enumerate(events, first):
            read(event, out, row)

    def read(self, event, out: dict[str, np.ndarray], row: int) -> None:
        """Write this event's sums per volume into ``out[quantity][row]`` (MeV, mm). The rows
        start at 0: a volume without hits keeps its 0."""
        hce = event.GetHCofThisEvent()
        if hce is None:
            return
        get = hce.GetHC
        for q, ids in zip(self.quantities, self.collection_ids, strict=True):
            target = out[q]
            for k, cid in enumerate(ids):
                hits = get(cid)
                n = hits.entries()
                if n == 1:  # one touchable (the usual case): its sum, without a generator
                    # next() once: unpacking would ask the binding's iterator for a second
                    # item, and its StopIteration is a C++ exception (~5 us, more when cold)
                    _, value = next(iter(hits))
                    target[row, k] = 0 + value  # as sum() gives it (-0.0 becomes 0.0)
                elif n:  # nothing deposited: the row keeps its 0
                    target[row, k] = sum(value for _, value in hits)
