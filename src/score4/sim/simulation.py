"""One Geant4 application in one process: geometry, physics, primaries, scoring.

A :class:`Simulation` is built once per worker process and then runs chunks of events;
each chunk reseeds Geant4, so a chunk's result does not depend on which worker ran it or
what ran before it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..config import RunConfig
from ..errors import ConfigError
from ..geometry.world import build_world, check_materials
from ..scene import build_scene
from ..source.build import make_source
from ..source.primaries import Primaries
from .physics import make_physics_list, set_production_cut, strip_data_hungry_processes
from .runtime import PhysicsChoice, import_geant4, redirect_native_output
from .scoring import VolumeScorer

_ION = re.compile(r"^([A-Z][a-z]?)-?(\d{1,3})$")


def resolve_particle(g4, name: str, parameter: str = "source.particle"):
    """G4ParticleDefinition for a Geant4 particle name or an ion such as "Pb206"."""
    table = g4.G4ParticleTable.GetParticleTable()
    particle = table.FindParticle(name)
    if particle is not None:
        return particle
    match = _ION.match(name)
    if match:
        z = g4.G4NistManager.Instance().GetZ(match.group(1))
        a = int(match.group(2))
        if z > 0 and a >= z:
            ion = g4.G4IonTable.GetIonTable().GetIon(int(z), a, 0.0)
            if ion is not None:
                return ion
    raise ConfigError(
        f"{parameter}: unknown particle {name!r}; use a Geant4 name (alpha, e-, e+, gamma, proton, "
        f"neutron, geantino) or an ion as element symbol + mass number (Pb206, Po210)"
    )


class Simulation:
    """Geant4 set up for one run configuration, in this process."""

    def __init__(
        self, config: RunConfig, choice: PhysicsChoice, log_path: Path | None = None
    ) -> None:
        self.config = config
        self.scene = build_scene(config)
        self.source = make_source(config, self.scene)
        self.choice = choice
        self.log_path = log_path
        self.quantities = ("edep", "track_length") if config.output.track_length else ("edep",)
        self._progress, self._reported, self._report_every = None, 0, 1  # see run()
        g4 = self.g4 = import_geant4(choice)
        with redirect_native_output(log_path):
            self._build(g4)

    def _build(self, g4) -> None:
        check_materials(g4, self.config)
        self.run_manager = g4.G4RunManagerFactory.CreateRunManager(g4.G4RunManagerType.Serial)
        ui = g4.G4UImanager.GetUIpointer()
        for cmd in (
            "/control/verbose 0",
            "/run/verbose 0",
            "/event/verbose 0",
            "/tracking/verbose 0",
        ):
            ui.ApplyCommand(cmd)
        sim = self

        class Detector(g4.G4VUserDetectorConstruction):
            def Construct(self):
                sim.geometry = build_world(g4, sim.config, sim.scene)
                sim.scorer = VolumeScorer(g4, sim.geometry.scoring, sim.quantities)
                return sim.geometry.world

            def ConstructSDandField(self):
                sim.scorer.attach()

        class Generator(g4.G4VUserPrimaryGeneratorAction):
            def __init__(self):
                super().__init__()
                self.gun = g4.G4ParticleGun(1)

            def GeneratePrimaries(self, event):
                sim._generate(self.gun, event)

        class EventAction(g4.G4UserEventAction):
            def EndOfEventAction(self, event):
                sim._score(event)
                sim._report_progress()

        # Geant4 requires this order: detector and physics registered before any user action exists.
        self._actions = [Detector(), make_physics_list(g4, self.choice)]
        self.run_manager.SetUserInitialization(self._actions[0])
        self.run_manager.SetUserInitialization(self._actions[1])
        set_production_cut(g4, self.config.physics.production_cut)
        self._actions += [Generator(), EventAction()]
        self.run_manager.SetUserAction(self._actions[2])
        self.run_manager.SetUserAction(self._actions[3])
        self.run_manager.Initialize()
        self.teleporter = None
        if self.geometry.portals:  # portal tiling: jumps between portal and subworlds
            from .portal_action import Teleporter, make_actions

            self.teleporter = Teleporter(g4, self.geometry.portals)
            stepping, tracking = make_actions(
                g4, self.teleporter, [p.region for p in self.geometry.portals]
            )
            self._actions += [
                stepping,
                tracking,
            ]  # stepping: the portal regions' own; tracking: idle
            self.run_manager.SetUserAction(tracking)
        self.removed_processes = (
            strip_data_hungry_processes(g4) if self.choice.mode == "lite" else []
        )
        self.scorer.resolve_ids()
        self._particles: dict[str, object] = {}
        self.volumes = list(self.scorer.names)
        for name in np.unique(self.source.primaries(np.random.default_rng(0), 0, 1).particle):
            self.particle(str(name))  # fail at start-up, before any output

    def particle(self, name: str):
        if name not in self._particles:
            self._particles[name] = resolve_particle(self.g4, name)
        return self._particles[name]

    def _generate(self, gun, event) -> None:
        k = self._next_event
        g4, p = self.g4, self._primaries
        if self.teleporter is not None:
            self.teleporter.begin_event(int(self._offsets[k]), int(self._offsets[k + 1]))
        for row in range(self._offsets[k], self._offsets[k + 1]):
            gun.SetParticleDefinition(self._defs[row])
            gun.SetParticleEnergy(p.energy[row])
            gun.SetParticlePosition(g4.G4ThreeVector(*self._positions[row]))
            gun.SetParticleMomentumDirection(g4.G4ThreeVector(*p.direction[row]))
            gun.GeneratePrimaryVertex(event)

    def _score(self, event) -> None:
        self.scorer.read(event, self._scores, self._next_event)
        self._next_event += 1

    def run(
        self, primaries: Primaries, g4_seed: int, progress=None, batch: int | None = None
    ) -> dict[str, np.ndarray]:
        """Track ``primaries``; return {quantity: (n_events, n_volumes) array} (MeV, mm).

        All events go into one ``BeamOn``: each ``BeamOn`` has a fixed cost that grows with the
        geometry (Geant4 walks the volume tree to update regions and cuts: 0.8 s with 4 million
        flat placements, see docs/tiling.md). ``progress(n)`` is called from the event action
        every ``batch`` events (default: a twentieth of the events) and once at the end.
        """
        for name in np.unique(primaries.particle):
            self.particle(str(name))
        n = primaries.n_events
        self._primaries = primaries
        # Portal tiling: vertices in a portal box start at their subworld point.
        self._positions = (
            primaries.position
            if self.teleporter is None
            else self.teleporter.map_primaries(primaries.position)
        )
        self._defs = [self._particles[str(name)] for name in primaries.particle]
        self._offsets = primaries.event_offsets()
        self._scores = {q: np.zeros((n, len(self.volumes))) for q in self.quantities}
        self._next_event = 0
        self.g4.G4Random.setTheSeed(int(g4_seed))
        self._progress, self._reported = progress, 0
        self._report_every = batch or max(1, n // 20)
        if n > 0:  # BeamOn(0) would still initialise a run
            with redirect_native_output(self.log_path):
                self.run_manager.BeamOn(n)
        self._report_progress(final=True)
        return self._scores

    def _report_progress(self, final: bool = False) -> None:
        """Call the progress callback with the events done since the last call (see :meth:`run`)."""
        done = self._next_event - self._reported
        if self._progress is not None and done > 0 and (final or done >= self._report_every):
            self._reported = self._next_event
            self._progress(done)
