"""One Geant4 application in one process: geometry, physics, primaries, scoring.

A :class:`Simulation` is built once per worker process and then runs chunks of events;
every event reseeds Geant4 with its own seed (:mod:`score4.runner.seeds`), so an event's result
does not depend on which worker ran it, what ran before it or how the run was chunked.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from score4.runner.run_plan import RunPlan
from score4.runner.seeds import library_trim_seed

from ..elements import split_ion_name
from ..errors import ConfigError, RunCancelled, Score4Error
from ..geometry.built import BuiltGeometry
from ..geometry.world import build_world, check_materials
from ..ions.trim_library import trim_histories
from ..source.build import FileSource
from ..source.decay_source import DecayEmitter
from ..source.emitters import NuclideEmitter, ParticleEmitter, Po210Emitter
from ..source.primaries import Primaries
from .feed import EventFeed, replay_row
from .heavy_ions import IonFate
from .implantation import AtomTracker, drop_lost, is_history
from .interception import InterceptedIon, make_stacking_action, needs_interception
from .physics import (
    drop_unused_parallel_world_region,
    idle_uncreated_particles,
    make_physics_list,
    set_production_cut,
    strip_data_hungry_processes,
)
from .runtime import import_geant4, redirect_native_output
from .scoring import SPLIT_QUANTITIES, VolumeScorer, ion_deposits
from .steps import StepRecorder, active_deposits, wants_steps

if TYPE_CHECKING:
    from .heavy_ions import HeavyIonTransport

#: Events per BeamOn at most. Geant4 keeps the events of a BeamOn until it ends (their scores
#: are read then, not by a Python event action at each event's end): ~1 kB an event plus
#: ~0.15 kB per scoring volume and quantity. A larger batch runs as several BeamOns.
KEPT_EVENTS = 10_000


def resolve_particle(g4, name: str, parameter: str = "source.particle"):
    """G4ParticleDefinition for a Geant4 particle name or an ion such as "Pb206"."""
    table = g4.G4ParticleTable.GetParticleTable()
    particle = table.FindParticle(name)
    if particle is not None:
        return particle
    ion = split_ion_name(name)
    if ion:
        z = g4.G4NistManager.Instance().GetZ(ion[0])
        a = ion[1]
        if z > 0 and a >= z:
            ion = g4.G4IonTable.GetIonTable().GetIon(int(z), a, 0.0)
            if ion is not None:
                return ion
    raise ConfigError(
        f"{parameter}: unknown particle {name!r}; use a Geant4 name (alpha, e-, e+, gamma, proton, "
        f"neutron, geantino) or an ion as element symbol + mass number (Pb206, Po210)"
    )


def source_particles(source) -> set[str] | None:
    """The names of the particles ``source`` can start (decays: none of
    :data:`~score4.sim.physics.UNCREATED_PARTICLES`, whatever they emit); None when unknown."""
    if isinstance(source, FileSource):
        return {str(name) for name in np.unique(source.primaries_all.particle)}
    emitter = getattr(source, "emitter", None)
    if isinstance(emitter, ParticleEmitter):
        return {emitter.particle}
    if isinstance(emitter, DecayEmitter | NuclideEmitter | Po210Emitter):
        return set()  # alphas, electrons, positrons, photons, neutrinos, nuclei
    return None


class Simulation:
    """Geant4 set up for one run configuration, in this process."""

    # set by the detector construction, during the run manager's Initialize()
    geometry: BuiltGeometry
    scorer: VolumeScorer
    _next_event: int
    _scores: dict[str, np.ndarray]

    def __init__(self, plan: RunPlan, log_path: Path | None = None) -> None:
        """The application of ``plan`` (:func:`score4.runner.run_plan.plan_run`): its scene, source
        and physics; the plan's seed fixes the TRIM seed of the trajectory libraries
        (:func:`score4.runner.seeds.library_trim_seed`). Geant4's console output goes to
        ``log_path``."""
        if plan.source is None:
            raise ValueError("Simulation: the plan has no source (made with source=False)")
        self.plan = plan
        config = self.config = plan.config
        self.run_seed = plan.seed
        self.scene = plan.scene
        self.source = plan.source
        self.choice = plan.physics
        self.log_path = log_path
        self.quantities: tuple[str, ...] = ("edep",)
        if config.output.track_length:
            self.quantities += ("track_length",)
        if config.output.split_by_particle:  # alpha and electron classes; ions are the rest
            self.quantities += SPLIT_QUANTITIES
        self._progress: Callable[[int], None] | None = None  # see run()
        self._reported, self._report_every = 0, 1
        self._stop: threading.Event | None = None  # see run()
        self._stopped = False
        g4 = self.g4 = import_geant4(plan.physics)
        with redirect_native_output(log_path):
            self._build(g4)

    def _build(self, g4) -> None:
        check_materials(g4, self.plan)
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
                sim.geometry = build_world(g4, sim.plan)
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

        # Geant4 requires this order: detector and physics registered before any user action exists.
        self._actions = [Detector(), make_physics_list(g4, self.choice)]
        self.run_manager.SetUserInitialization(self._actions[0])
        self.run_manager.SetUserInitialization(self._actions[1])
        set_production_cut(g4, self.config.physics.production_cut)
        # No event action: the primary generator closes each event when the next one starts,
        # and the scores are read after each BeamOn (see run)
        self._actions.append(Generator())
        self.run_manager.SetUserAction(self._actions[2])
        drop_unused_parallel_world_region(g4)
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
        #: lite mode: particles no process creates and the source does not start, without
        #: tables (no effect on any result; see idle_uncreated_particles)
        self.idle_particles = (
            idle_uncreated_particles(g4, source_particles(self.source))
            if self.choice.mode == "lite"
            else []
        )
        #: steps with a deposit (output.steps, targets[].activeness), else None: no Python per step
        self.steps: StepRecorder | None = None
        if wants_steps(self.config):
            if self.geometry.portals:
                raise ConfigError(
                    "output.steps: steps (and activeness) need native tiling; a portal layer "
                    "has a stepping action of its own"
                )
            self.steps = StepRecorder(
                g4, self.geometry.scoring, list(self.scorer.names), lambda: self._next_event
            )
            self.run_manager.SetUserAction(self.steps.action)
        self.activeness = None
        #: per scoring column, distances to its volume's faces (steps and activeness), else None
        self.distances = None
        if self.steps is not None:
            from ..world.activeness import target_distances

            self.distances = target_distances(self.scene)
        if any(t.config.activeness for t in self.scene.targets):
            from ..world.activeness import volume_activeness

            self.activeness = volume_activeness(self.scene, self.distances)
        #: the steps of the last run (event indices of its batch), when recorded
        self.last_steps: dict[str, np.ndarray] | None = None
        self.scorer.resolve_ids()
        self.heavy_ions: HeavyIonTransport | None = None
        if "trim" in (self.config.physics.heavy_ions, self.config.physics.alphas):
            from .heavy_ions import HeavyIonTransport

            self.heavy_ions = HeavyIonTransport(
                g4,
                self.geometry.world,
                self.geometry.scoring,
                histories=trim_histories(self.config),
                library_seed=library_trim_seed(self.run_seed),
            )
            # steps: the replayed ions' deposits piece by piece along their paths
            self.heavy_ions.record_pieces = self.steps is not None
        self._endpoint_action: Any = None
        self._next_event = 0  # index in the batch of the event being tracked
        self._started = 0  # events of the batch generated so far
        self._open = False  # event _next_event is generated and not yet closed (_close_event)
        #: replayed ions of the closed events whose Geant4 scores are not read yet
        self._books: list[tuple[int, IonFate, bool]] | None = None
        self._replaying = False  # this batch has heavy ions to replay
        self._interceptor: Any = None  # stacking action for heavy-ion secondaries, once needed
        #: heavy-ion secondaries taken from Geant4 in the last :meth:`run` (``interception``)
        self.intercepted: list[InterceptedIon] = []
        self._pushes_before = 0
        #: how each replayed primary ended in the last :meth:`run`: {row of primaries: fate}
        self.ion_fates: dict[int, IonFate] = {}
        #: the atoms of the last :meth:`run` of per-atom histories (None for other batches)
        self.atoms: AtomTracker | None = None
        self._units_after: np.ndarray | None = None
        self.endpoints: np.ndarray | None = None
        self._particles: dict[str, object] = {}
        self.volumes = list(self.scorer.names)
        for name in np.unique(self.source.primaries(np.random.default_rng(0), 0, 1).particle):
            self.particle(str(name))  # fail at start-up, before any output

    def particle(self, name: str):
        if name not in self._particles:
            self._particles[name] = resolve_particle(self.g4, name)
        return self._particles[name]

    def trim_rows(self, primaries: Primaries) -> np.ndarray:
        """Rows of ``primaries`` that follow TRIM trajectories instead of Geant4
        (:func:`score4.sim.heavy_ions.trim_mask` with the run's physics settings)."""
        if self.heavy_ions is None:
            return np.zeros(len(primaries), dtype=bool)
        from .heavy_ions import trim_mask

        physics = self.config.physics
        return trim_mask(
            primaries, self.particle, physics.heavy_ions, physics.alphas, physics.trim_max_energy
        )

    def untracked_rows(self, primaries: Primaries) -> np.ndarray:
        """Rows of ``primaries`` that are photons lite physics cannot track (no data-free
        photoelectric model in Geant4 11.4: docs/physics.md#gammas-and-x-rays-in-lite-mode).
        Their energies are counted per event (:meth:`event_columns`), not given to Geant4."""
        if self.choice.mode != "lite":
            return np.zeros(len(primaries), dtype=bool)
        return np.asarray(primaries.particle == "gamma")

    def event_columns(self) -> dict[str, np.ndarray]:
        """More per-event columns of the last :meth:`run` for the results file.

        Lite physics: ``untracked_gamma_energy`` (MeV), the energy of the event's photons
        (gamma and X-ray primaries, annihilation photons) that were not tracked."""
        if self.choice.mode != "lite":
            return {}
        return {"untracked_gamma_energy": self.untracked_gamma}

    def untrack(self, k: int, energy: float) -> None:
        """Count a photon of ``energy`` MeV that event ``k`` created and lite physics drops."""
        self.untracked_gamma[k] += energy

    def _generate(self, gun, event) -> None:
        """Geant4's primary generator, the only Python call per event: close the event before
        (:meth:`_close_event`), stop if asked to, then fill event ``k``. Geant4 keeps the
        event: its scores are read after the BeamOn (:meth:`_read_scores`)."""
        k = self._started
        if self._open:
            self._close_event(k - 1)
        if self._check_stop():
            return  # this event stays empty; Geant4 starts no other
        self._started = k + 1
        self._next_event, self._open = k, True
        event.KeepTheEvent(True)
        feed = self._feed
        if self._replaying:  # heavy ions first: an implanted daughter starts where one stopped
            self._replay_event(k)
        if self.teleporter is not None:
            self.teleporter.begin_event(int(feed.offsets[k]), int(feed.offsets[k + 1]))
        feed.fill(gun, event, k)  # not the rows replayed on TRIM or gammas lite cannot track

    def _close_event(self, k: int) -> None:
        """Event ``k`` is complete: its replayed ions join it (their steps now, their scores
        after its Geant4 scores are read), and progress is reported."""
        self._open = False
        if self._pending or self._replayed:
            # heavy-ion secondaries replayed during the event, then its heavy-ion primaries
            # replayed before it
            for fate, alpha in (*self._pending, *self._replayed):
                self._book_steps(k, fate)
                assert self._books is not None  # set for the run
                self._books.append((k, fate, alpha))
            self._pending.clear()
            self._replayed.clear()
        if self._progress is not None:
            self._report_progress(k + 1)

    def _beam_on(self, n: int) -> None:
        """Track events ``self._started ..`` of the batch, ``n`` at most (fewer when stopped),
        in one BeamOn, then read their scores."""
        first = self._started
        with redirect_native_output(self.log_path):
            self.run_manager.BeamOn(n)
        if self._open:
            self._close_event(self._started - 1)
        if not self._stopped:
            self._read_scores(first)

    def _read_scores(self, first: int) -> None:
        """The scores of the events Geant4 kept in the last BeamOn (rows ``first ..``), then
        the replayed ions booked to them."""
        events = self.run_manager.GetCurrentRun().GetEventVector()
        if len(events) != self._started - first:
            raise Score4Error(
                f"Geant4 kept {len(events)} events of the {self._started - first} tracked"
            )
        self.scorer.read_events(events, self._scores, first)
        del events  # the run owns them: Geant4 deletes them at the next BeamOn
        assert self._books is not None
        for k, fate, alpha in self._books:
            self._book_scores(k, fate, alpha)
        self._books.clear()

    def run(
        self,
        primaries: Primaries,
        g4_seed: int | np.ndarray,
        progress=None,
        batch: int | None = None,
        endpoints: bool = False,
        stop: threading.Event | None = None,
    ) -> dict[str, np.ndarray]:
        """Track ``primaries``; return {quantity: (n_events, n_volumes) array} (MeV, mm).

        ``g4_seed`` is one seed for the whole batch, or one seed per event (``(n_events,)``
        integers, see :func:`score4.runner.seeds.event_geant4_seeds`): each event then starts
        from its own seed and its result does not depend on the events run before it.
        All events go into one ``BeamOn``: each ``BeamOn`` has a fixed cost that grows with the
        geometry (Geant4 walks the volume tree to update regions and cuts: 0.8 s with 4 million
        flat placements, see docs/tiling.md). ``progress(n)`` is called from the event action
        every ``batch`` events (default: a twentieth of the events) and once at the end.
        Heavy ions (:meth:`trim_rows`) are moved along TRIM trajectories
        (:mod:`score4.sim.heavy_ions`) all before Geant4 tracks the batch, each from its own
        random stream (with per-atom histories just before Geant4 tracks their event: a
        daughter starts where its recoil stopped); their deposits join their events'.
        With ``endpoints=True``, ``self.endpoints`` is then an (n_rows, 4) array: where each
        primary ended (x, y, z mm) and its kinetic energy there (MeV; > 0 if it left the world).
        ``stop``, set from another thread, ends the run after the event being tracked
        (:meth:`_check_stop`) and raises :class:`RunCancelled`; the application stays usable.
        """
        names = [str(name) for name in np.unique(primaries.particle)]
        for name in names:
            self.particle(name)
            if name in self.idle_particles:  # source_particles did not foresee it
                raise Score4Error(f"run: {name} primaries, but {name} has no physics processes")
        n = primaries.n_events
        self._primaries = primaries
        # Portal tiling: vertices in a portal box start at their subworld point.
        positions = (
            primaries.position
            if self.teleporter is None
            else self.teleporter.map_primaries(primaries.position)
        )
        definitions = [self._particles[str(name)] for name in primaries.particle]
        self._trim = self.trim_rows(primaries)
        self._scores = {q: np.zeros((n, len(self.volumes))) for q in self.quantities}
        self._untracked_rows = (
            self.untracked_rows(primaries)
            if "gamma" in names
            else np.zeros(len(primaries), dtype=bool)
        )
        self._skip = self._trim | self._untracked_rows
        self._feed = EventFeed(
            self.g4, primaries, definitions, g4_seed, self._skip, positions, own_gun=True
        )
        self.untracked_gamma = np.bincount(
            primaries.event[self._untracked_rows],
            weights=primaries.energy[self._untracked_rows],
            minlength=n,
        ).astype(float)
        self.endpoints = np.full((len(primaries), 4), np.nan) if endpoints else None
        self._track_endpoints(endpoints)
        self._pushes_before = 0 if self.heavy_ions is None else self.heavy_ions.pushes
        self._prepare_replay(primaries, g4_seed)
        self._prepare_atoms(primaries)
        self.intercepted, self.ion_fates = [], {}
        self._pending: list[tuple[IonFate, bool]] = []
        self._replayed: list[tuple[IonFate, bool]] = []
        self._early: dict[int, list[tuple[IonFate, bool]]] = {}
        if self._replaying and self.atoms is None:
            with redirect_native_output(self.log_path):  # the navigator's warnings to the log
                self._replay_all(stop)
        self._intercept(names)
        if self.steps is not None:
            self.steps.take()  # nothing left from a cancelled run
        self._next_event, self._started, self._open, self._books = 0, 0, False, []
        if np.ndim(g4_seed) == 0:
            self.g4.G4Random.setTheSeed(int(g4_seed))
        self._progress, self._reported = progress, 0
        units = n if self._units_after is None else int(self._units_after[-1])
        self._report_every = batch or max(1, units // 20)
        self._stop, self._stopped = stop, False
        try:
            # BeamOn(0) still starts a run; a batch of many events runs as several BeamOns
            # (KEPT_EVENTS: Geant4 keeps the events of a BeamOn until it ends)
            while self._started < n and not self._stopped:
                if stop is not None and stop.is_set():
                    break
                self._beam_on(min(n - self._started, KEPT_EVENTS))
        finally:
            self._stop, self._open, self._books = None, False, None
        if self.atoms is not None:
            self.atoms.finish()
        if self._stopped or (stop is not None and stop.is_set()):
            raise RunCancelled(f"run cancelled after {self._started} of {n} events")
        self._report_progress(self._started, final=True)
        if "edep_alpha" in self._scores:
            self._scores["edep_ion"] = ion_deposits(self._scores)
        if self.steps is not None:
            self.last_steps = self.steps.take()
            if self.activeness is not None:
                self._scores["active_edep"] = active_deposits(
                    self.last_steps, self.activeness, self._scores["edep"]
                )
        return self._scores

    def _prepare_atoms(self, primaries: Primaries) -> None:
        """Per-atom histories (a chain with implantation): follow the atoms
        (:class:`score4.sim.implantation.AtomTracker`); progress counts atoms."""
        self.atoms, self._units_after = None, None
        if not is_history(primaries):
            return
        if self.heavy_ions is None or self.config.physics.heavy_ions != "trim":
            raise ConfigError(
                "source.decay.implantation: needs physics.heavy_ions: trim (per-atom histories "
                "move each daughter to where the TRIM replay stopped its alpha recoil)"
            )
        if self.teleporter is not None:
            raise ConfigError(
                "source.decay.implantation: needs native tiling (a recoil in a portal subworld "
                "stops at no place of the world)"
            )
        self.atoms = AtomTracker(
            primaries, self._feed.positions, self.heavy_ions, self._depth_function(primaries)
        )
        self._replaying = True  # the tracker places every decay, also without heavy ions
        # atoms whose events are all done after k events (the progress unit)
        atom_of_event = primaries.extra["atom"][self._feed.offsets[:-1]]
        last = np.r_[atom_of_event[1:] != atom_of_event[:-1], True]
        self._units_after = np.r_[0, np.cumsum(last)]

    def _depth_function(self, primaries: Primaries):
        """``depth_of(points, rows)`` for the moved vertices of per-atom histories drawn below
        a surface (None for a bulk source: no depth)."""
        sampler: Any = getattr(self.source, "sampler", None)
        ex = primaries.extra
        if not hasattr(sampler, "depth_of") or "depth" not in ex or "normal_x" not in ex:
            return None
        normal = np.column_stack([ex[f"normal_{a}"] for a in "xyz"])
        depth, position = ex["depth"].copy(), primaries.position.copy()  # as deposited
        face = ex.get("face")

        def depth_of(points: np.ndarray, rows: np.ndarray) -> np.ndarray:
            return sampler.depth_of(
                points,
                position[rows],
                normal[rows],
                depth[rows],
                None if face is None else face[rows],
            )

        return depth_of

    def run_counts(self) -> dict:
        """Counts of the last :meth:`run` for the run record: ``intercepted_ions`` (heavy-ion
        secondaries taken from Geant4 and replayed), ``reinjected_ions`` (of them, sent back
        to Geant4 to decay), ``replay_pushes`` (stuck replayed ions G4Navigator pushed 1e-7 mm:
        :meth:`score4.sim.heavy_ions.HeavyIonTransport._locate_after`); ``implantation``
        (per-atom histories: :meth:`score4.sim.implantation.AtomTracker.summary`)."""
        out: dict = {
            "intercepted_ions": len(self.intercepted),
            "reinjected_ions": sum(1 for ion in self.intercepted if ion.reinjected),
        }
        if self.heavy_ions is not None:
            out["replay_pushes"] = self.heavy_ions.pushes - self._pushes_before
        if self.atoms is not None:
            out["implantation"] = self.atoms.summary()
        return out

    def step_table(self) -> dict[str, np.ndarray] | None:
        """The last run's steps (after :meth:`drop_lost`) with ``dist``, each step's distance to
        the surface of its volume (mm, exact, :mod:`score4.shapes`; a face with a flat rough
        layer by its rough surface, :class:`score4.world.activeness.TargetDistance`); None when
        steps are not recorded or not asked for (``output.steps``)."""
        if self.last_steps is None or not self.config.output.steps:
            return None
        steps = dict(self.last_steps)
        dist = np.zeros(len(steps["edep"]))
        points = np.column_stack([steps["x"], steps["y"], steps["z"]])
        assert self.distances is not None  # built with the step recorder
        for c, distance in enumerate(self.distances):
            rows = steps["volume"] == c
            if not rows.any():
                continue
            if distance is None:  # a solid score4.shapes cannot describe
                dist[rows] = np.nan
                continue
            dist[rows] = distance.to_surface(points[rows])
        steps["dist"] = dist
        return steps

    def drop_lost(
        self, primaries: Primaries, scores: dict[str, np.ndarray]
    ) -> tuple[Primaries, dict[str, np.ndarray]]:
        """The last :meth:`run`'s ``primaries`` and ``scores`` without the decays lost with
        their atoms (:func:`score4.sim.implantation.drop_lost`); :meth:`event_columns` then
        describes the events that remain."""
        n = primaries.n_events
        kept_events = np.ones(n, dtype=bool)
        vertex = primaries.extra.get("vertex")
        if vertex is not None:
            kept_events[:] = False
            kept_events[primaries.event[vertex != 3]] = True  # implantation.LOST
        primaries, scores, columns, dropped = drop_lost(primaries, scores, self.event_columns())
        if dropped and self.last_steps is not None:  # steps of kept events, renumbered
            renumber = np.cumsum(kept_events) - 1
            keep = kept_events[self.last_steps["event"]]
            self.last_steps = {k: v[keep] for k, v in self.last_steps.items()}
            self.last_steps["event"] = renumber[self.last_steps["event"]]
        if dropped and self.atoms is not None:
            self.atoms.counts["lost_events"] += dropped
            if "untracked_gamma_energy" in columns:
                self.untracked_gamma = columns["untracked_gamma_energy"]
        return primaries, scores

    def _prepare_replay(self, primaries: Primaries, g4_seed: int | np.ndarray) -> None:
        """Heavy ions of this batch: one library per ion, start energy and material announced."""
        self._replaying = bool(self._trim.any())
        self._replay_seeds = np.asarray(g4_seed)
        if not self._replaying:
            return
        transport = self.heavy_ions
        assert transport is not None  # rows are only marked for TRIM when it exists
        # one library per ion, start energy and material
        rows = self._trim
        for name, energy in set(zip(primaries.particle[rows], primaries.energy[rows], strict=True)):
            transport.need(str(name), float(energy))

    # -- heavy-ion secondaries (score4.sim.interception) -------------------------------------

    @property
    def max_energy(self) -> float:
        return float(self.config.physics.trim_max_energy)

    @property
    def decay(self) -> bool:
        return bool(self.choice.decay)

    def current_event(self) -> tuple[int, int]:
        """(index in the batch, seed) of the event Geant4 is tracking."""
        k = self._next_event
        seeds = self._replay_seeds
        return k, int(seeds) * 1_000_003 + k if seeds.ndim == 0 else int(seeds[k])

    def book(self, k: int, fate: IonFate, alpha: bool = False) -> None:
        """Add a replayed ion's deposits (and track lengths) to event ``k``; ``alpha``: an alpha
        on TRIM (``alphas: trim``), whose deposits also count in the alpha class when split.

        While Geant4 tracks event ``k`` they wait: they join it when it is complete
        (:meth:`_close_event`); during a run, after its Geant4 scores are read."""
        if self._open and k == self._next_event:
            self._pending.append((fate, alpha))
            return
        self._book_steps(k, fate)
        if self._books is not None:  # a run: Geant4's scores of event k are not read yet
            self._books.append((k, fate, alpha))
        else:
            self._book_scores(k, fate, alpha)

    def _book_steps(self, k: int, fate: IonFate) -> None:
        """A replayed ion's deposits as steps of event ``k`` (when steps are recorded)."""
        steps = self.steps
        if steps is None:
            return
        if not fate.pieces:
            for volume, value in fate.deposits.items():
                if value > 0.0:
                    where = fate.points.get(volume, fate.position)
                    steps.add(k, volume, fate.pdg, value, where, fate.time)
        for volume, x, y, z, value in fate.pieces:  # the path's pieces, each a step
            if value > 0.0:
                steps.add(k, volume, fate.pdg, value, (x, y, z), fate.time)

    def _book_scores(self, k: int, fate: IonFate, alpha: bool) -> None:
        """Add a replayed ion's deposits and track lengths to the scores of event ``k``."""
        for volume, value in fate.deposits.items():
            self._scores["edep"][k, volume] += value
            if alpha and "edep_alpha" in self._scores:
                self._scores["edep_alpha"][k, volume] += value
        if "track_length" in self._scores:
            for volume, value in fate.lengths.items():
                self._scores["track_length"][k, volume] += value

    def _intercept(self, names: list[str]) -> None:
        """Install the stacking action when this batch (its primaries' particle ``names``) can
        create heavy-ion secondaries, or photons lite physics must count (positrons
        annihilate into two)."""
        from .heavy_ions import heavy_ion_z

        def is_ion(name: str) -> bool:
            p = self.particle(name)
            return bool(heavy_ion_z(p)) or str(p.GetParticleType()) == "nucleus"

        heavy = (
            self.heavy_ions is not None
            and self.config.physics.heavy_ions == "trim"
            and needs_interception(names, is_ion, self.decay)
        )
        gammas = self.choice.mode == "lite" and "e+" in names
        if not (heavy or gammas):
            return
        if self._interceptor is None:
            self._interceptor = make_stacking_action(self.g4, self.heavy_ions, self)
            self.run_manager.SetUserAction(self._interceptor)
        self._interceptor.heavy |= heavy
        self._interceptor.gammas |= gammas

    def _replay_event(self, k: int) -> None:
        """Before Geant4 tracks event ``k``: have its heavy ions' deposits join the event's at
        its end (replayed before the run: :meth:`_replay_all`); with per-atom histories,
        replay them now and put each decay where its atom is first
        (:class:`~score4.sim.implantation.AtomTracker`)."""
        feed, atoms = self._feed, self.atoms
        if atoms is None:  # replayed before the run (_replay_all)
            self._replayed.extend(self._early.pop(k, ()))
            return
        decay = atoms.decay_index
        a, end = int(feed.offsets[k]), int(feed.offsets[k + 1])
        while a < end:  # one decay (rows a .. b - 1) at a time, in decay order
            b = a + 1
            while b < end and decay[b] == decay[a]:
                b += 1
            if not atoms.place(a, b):
                self._lose(k, a, b)
            else:
                for row in range(a, b):
                    if self._trim[row]:
                        fate = self._replay_row(k, row)
                        self._replayed.append((fate, self._is_alpha(row)))
                        if atoms.recoil[row]:
                            atoms.moved(row, fate)
                    elif atoms.recoil[row]:
                        atoms.not_replayed(row)
            a = b

    def _lose(self, k: int, a: int, b: int) -> None:
        """Rows ``a .. b - 1`` of event ``k`` are not emitted: their atom left the world."""
        feed = self._feed
        feed.skip[a:b] = True
        untracked = self._untracked_rows[a:b]
        if untracked.any():
            self._untracked_rows[a:b] = False
            rows = slice(int(feed.offsets[k]), int(feed.offsets[k + 1]))
            kept = self._untracked_rows[rows]
            self.untracked_gamma[k] = float(feed.primaries.energy[rows][kept].sum())

    def _replay_all(self, stop: threading.Event | None = None) -> None:
        """Replay the heavy ions of every event of the batch, in event order, before Geant4
        tracks any (without per-atom histories nothing of Geant4's tracking changes a replay):
        one tight loop keeps the replay's code and data in the CPU's caches, which a replay
        between two Geant4 events finds cold (it then costs about twice as much:
        ``benchmarks/bench_replay_speed.py``). Each event books its fates at its end.
        ``stop`` (see :meth:`run`) is looked at every 1000 ions."""
        feed, early = self._feed, self._early
        event = feed.primaries.event
        for n, row in enumerate(np.flatnonzero(self._trim).tolist()):
            if n % 1000 == 999 and stop is not None and stop.is_set():
                raise RunCancelled(f"run cancelled after 0 of {feed.n_events} events")
            k = int(event[row])
            early.setdefault(k, []).append((self._replay_row(k, row), self._is_alpha(row)))

    def _is_alpha(self, row: int) -> bool:
        """Row ``row`` is an alpha (on TRIM with ``alphas: trim``): its deposits also count in
        the alpha class."""
        return str(self._feed.primaries.particle[row]) == "alpha"

    def _replay_row(self, k: int, row: int) -> IonFate:
        """Replay the heavy ion of ``row`` (event ``k``); the caller books its deposits into
        the event's at its end (:meth:`_replay_all`, :meth:`_replay_event`)."""
        transport, feed = self.heavy_ions, self._feed
        assert transport is not None
        fate = replay_row(transport, feed, k, row)
        self.ion_fates[row] = fate
        if self.endpoints is not None:
            self.endpoints[row] = (*fate.position, fate.escaped_energy)
        return fate

    def _track_endpoints(self, on: bool) -> None:
        """Record where Geant4's primaries end (a Python tracking action, only when asked)."""
        if not on:
            if self._endpoint_action is not None:
                self.run_manager.SetUserAction(self._null_tracking())
                self._endpoint_action = None
            return
        if self.teleporter is not None:
            raise Score4Error("primary end points are not available with portal tiling")
        g4: Any = self.g4
        sim = self

        class Endpoints(g4.G4UserTrackingAction):
            def PostUserTrackingAction(self, track):
                if track.GetParentID() != 0 or sim.endpoints is None:
                    return
                rows = sim._g4_rows_of_event(sim._next_event)
                row = rows[track.GetTrackID() - 1]
                p = track.GetPosition()
                sim.endpoints[row] = (p.x, p.y, p.z, track.GetKineticEnergy())

        self._endpoint_action = Endpoints()
        self.run_manager.SetUserAction(self._endpoint_action)

    def _null_tracking(self):
        self._null_action = self.g4.G4UserTrackingAction()
        return self._null_action

    def _g4_rows_of_event(self, k: int) -> list[int]:
        return self._feed.geant4_rows(k)

    def _check_stop(self) -> bool:
        """Whether the run stops before the next event because it was asked to (one attribute
        test per event); the first time, end the run after the event Geant4 is starting."""
        if self._stop is None or not self._stop.is_set():
            return False
        if not self._stopped:
            self._stopped = True
            self.run_manager.AbortRun(True)  # soft: the current event is processed, no new one
        return True

    def _report_progress(self, k: int, final: bool = False) -> None:
        """Call the progress callback with the events (atoms, for per-atom histories) done
        since the last call, ``k`` events of the batch being done (see :meth:`run`)."""
        now = k if self._units_after is None else int(self._units_after[k])
        done = now - self._reported
        if self._progress is not None and done > 0 and (final or done >= self._report_every):
            self._reported = now
            self._progress(done)
