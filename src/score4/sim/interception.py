"""Heavy ions that Geant4 creates as secondaries, taken from Geant4 and replayed on TRIM.

Primaries that are heavy ions are never given to Geant4 (:meth:`Simulation.trim_rows`). Heavy
ions can also be *created* during an event: the recoiling daughter of an alpha decay in
Geant4's radioactive decay (``source.nuclide``, full physics), or a target nucleus knocked on by
a proton, muon or pion through single Coulomb scattering (any mode). Geant4 ranges them as
badly as it ranges primaries, so a user stacking action takes every new heavy ion (Z > 2) of
kinetic energy in [:data:`MIN_ENERGY`, ``physics.trim_max_energy``] as it is created,
replays it on TRIM trajectories (:class:`score4.sim.heavy_ions.HeavyIonTransport`) and books
its deposits in the event. Then:

* an unstable ion that came to rest in matter (radioactive decay registered and the ion not
  stable) goes back to Geant4 where it stopped, with zero kinetic energy, so Geant4's
  radioactive decay continues the chain from there;
* any other ion is killed (its energy is already deposited, or left the world).

Python runs once per new track (``ClassifyNewTrack``), not per step; the action is installed
only for runs whose sources can create such ions (:func:`needs_interception`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..elements import ground_state_name
from .heavy_ions import HeavyIonTransport, IonFate, ReplayStream, heavy_ion_z

#: Ions created below this kinetic energy (MeV) stay with Geant4: beta-decay recoils (eV) and
#: de-excitation recoils, whose ranges (< 1 nm) are below what TRIM or the geometry resolve.
MIN_ENERGY = 1e-3
#: Primary particles whose processes in score4's physics lists create no heavy-ion secondaries
#: (no single Coulomb scattering below 100 MeV, no hadronic physics): no stacking action needed.
RECOIL_FREE = frozenset(
    {"alpha", "He3", "e-", "e+", "gamma", "geantino", "chargedgeantino", "neutron", "opticalphoton"}
)
#: Libraries for intercepted ions are built at energies on a grid of this many per decade (an
#: ion continues a history of the next grid energy above its own, from inside: unbiased to 1 %,
#: ``tests/test_trim_library.py``), so continuous recoil spectra need a few libraries, not one
#: per energy.
GRID_PER_DECADE = 8
_STREAM = 0x5C0E5  # mixed into the seeds of the random streams of intercepted ions


def needs_interception(names, is_ion, decay: bool) -> bool:
    """Whether a batch with primaries ``names`` can create heavy-ion secondaries.

    ``is_ion(name)``: whether the primary is an ion (Z > 2 or any nucleus: its own processes
    create none); ``decay``: radioactive decay registered (a decaying nucleus creates its
    daughter).
    """
    return decay or any(n not in RECOIL_FREE and not is_ion(n) for n in names)


def grid_energy(energy: float) -> float:
    """The library energy (MeV) for an intercepted ion of ``energy``: the grid value >= it."""
    exponent = math.ceil(GRID_PER_DECADE * math.log10(energy) - 1e-9)
    return round(10.0 ** (exponent / GRID_PER_DECADE), 12)


def ion_name(particle) -> str:
    """The ground-state name of a Geant4 ion ("Pb206" for "Pb206[803.054]")."""
    return ground_state_name(str(particle.GetParticleName()))


@dataclass
class InterceptedIon:
    """A heavy ion taken from Geant4 and replayed: where it began and how it ended.

    ``fate.position``, ``fate.volume`` and ``fate.material`` give where it stopped (or left
    the world); ``reinjected`` is True when it went back to Geant4 there to decay.
    """

    event: int  # index of the event in the batch
    ion: str  # Geant4 name, with its excitation if any
    energy: float  # MeV at creation
    position: np.ndarray  # (3,) mm at creation
    direction: np.ndarray  # (3,) unit
    fate: IonFate
    reinjected: bool


def make_stacking_action(g4, transport: HeavyIonTransport | None, state):
    """A G4UserStackingAction that intercepts heavy-ion secondaries (see the module docstring)
    when its ``heavy`` is set, and kills and counts new photons when its ``gammas`` is set
    (lite physics: Geant4 has no data-free photoelectric model).

    ``state`` is the object that knows the event being tracked: it must have
    ``current_event() -> (index, seed)``, ``max_energy`` (MeV), ``decay`` (bool),
    ``book(event, fate)`` (adds the fate's deposits to that event), ``untrack(event,
    energy)`` (counts a dropped photon) and a list ``intercepted`` (receives
    :class:`InterceptedIon` records).
    """
    urgent = g4.G4ClassificationOfNewTrack.fUrgent
    kill = g4.G4ClassificationOfNewTrack.fKill
    vector = g4.G4ThreeVector

    class Interceptor(g4.G4UserStackingAction):
        def __init__(self) -> None:
            super().__init__()
            # id(definition) -> (definition, Z of a heavy ion or 0, is a photon)
            self.kinds: dict[int, tuple[object, int, bool]] = {}
            self.counter = 0
            self.heavy = False  # intercept heavy ions
            self.gammas = False  # kill and count photons
            self.reinject_stable = False  # test hook: send stable ions back to Geant4 too

        def PrepareNewEvent(self) -> None:
            self.counter = 0

        def ClassifyNewTrack(self, track):
            # (primary heavy ions in the energy range never reach Geant4: no parent test needed)
            definition = track.GetDefinition()
            kind = self.kinds.get(id(definition))
            if kind is None:  # keep the definition alive: its id stays its own
                photon = str(definition.GetParticleName()) == "gamma"
                kind = (definition, heavy_ion_z(definition), photon)
                self.kinds[id(definition)] = kind
            if kind[2] and self.gammas:
                state.untrack(state.current_event()[0], track.GetKineticEnergy())
                return kill
            if not (kind[1] and self.heavy):
                return urgent
            energy = track.GetKineticEnergy()
            if not MIN_ENERGY <= energy <= state.max_energy:
                return urgent
            return self.replay(track, definition, energy)

        def replay(self, track, definition, energy: float):
            event, seed = state.current_event()
            p, d = track.GetPosition(), track.GetMomentumDirection()
            position = np.array([p.x, p.y, p.z])
            direction = np.array([d.x, d.y, d.z])
            rng = ReplayStream(seed, _STREAM, self.counter)
            self.counter += 1
            name = ion_name(definition)
            assert transport is not None  # `heavy` is only set with a transport
            transport.need(name, max(grid_energy(energy), energy))
            fate = transport.transport(
                definition, name, energy, position, direction, rng, announce=False
            )
            fate.time = track.GetGlobalTime()
            state.book(event, fate)
            unstable = state.decay and not definition.GetPDGStable()
            back = fate.stopped and (unstable or self.reinject_stable)
            state.intercepted.append(
                InterceptedIon(
                    event,
                    str(definition.GetParticleName()),
                    energy,
                    position,
                    direction,
                    fate,
                    back,
                )
            )
            if not back:
                return kill
            # at rest where TRIM stopped it: Geant4 locates it there and lets it decay
            track.SetPosition(vector(*(float(c) for c in fate.position)))
            track.SetKineticEnergy(0.0)
            return urgent

    return Interceptor()
