"""Physics lists: ``full`` (EM option4, optional radioactive decay) and ``lite`` (no data)."""

from __future__ import annotations

from .runtime import PhysicsChoice

# Processes that read G4EMLOW data at the first event; lite mode removes them after
# initialisation (found by trial: everything else in option0 runs without data files).
LITE_REMOVED_PROCESSES = {"e-": ("eBrem",), "e+": ("eBrem",), "gamma": ("GammaGeneralProc",)}
# Nuclear stopping (G4NuclearStopping) is registered for alphas and ions below this kinetic
# energy; 0 registers none. It is off because it breaks energy conservation (measured with
# Geant4 11.4.1, option0; benchmarks/bench_energy_conservation.py): it caps its loss at the
# pre-step energy instead of the energy ionisation left, and G4ParticleChangeForLoss sets a
# negative final energy to 0 without taking the difference back from the deposit, so a long step
# of a slow ion deposits more than the ion had (1 MeV limit: 5.3 MeV alphas on pyramids 10 of
# 20000 events above 5.3 MeV; Po-210 on a flat face 38 of 2000; 0 of each with 0). It changes
# alpha depths by < 0.5 %, and Pb-206 recoils are far from TRIM either way
# (benchmarks/bench_ion_setups.py). The same G4NuclearStopping would serve option4 (full mode).
MAX_NIEL_ENERGY_MEV = 0.0
# Step function of alphas and He-3 (dRoverRange, finalRange in mm): Geant4's default lets an alpha
# below ~1-5 MeV cross its whole remaining range in one or two steps, straight, so it ends
# 10-29 % deeper than TRIM at 1 MeV (Si: 4.12 vs 3.49 um). (0.05, 0.1 um) gives alpha depths
# within 3 % of TRIM at 1, 3 and 5.3 MeV in Si, Ge and Cu (Si 5.3 MeV: 0.983) at about the same
# CPU (benchmarks/bench_ion_setups.py); CaWO4, NaI and TeO2 keep up to 6 % off where Geant4's
# alpha stopping powers differ from SRIM's by 4-8 %.
LIGHT_ION_STEP_FUNCTION = (0.05, 1e-4)


def make_physics_list(g4, choice: PhysicsChoice):
    """Return a modular physics list for ``choice`` (to be given to the run manager)."""

    class ModularPhysics(g4.G4VModularPhysicsList):
        def __init__(self) -> None:
            super().__init__()
            self.SetVerboseLevel(0)
            if choice.mode == "full":
                self.RegisterPhysics(g4.G4EmStandardPhysics_option4())
            else:
                self.RegisterPhysics(g4.G4EmStandardPhysics())
            if choice.decay:
                self.RegisterPhysics(g4.G4DecayPhysics())
                self.RegisterPhysics(g4.G4RadioactiveDecayPhysics())
            # After the EM constructor, whose constructor resets the parameters to defaults
            # (option3/option4 turn nuclear stopping on: this turns it off again).
            params = g4.G4EmParameters.Instance()
            params.SetVerbose(0)
            params.SetMaxNIELEnergy(MAX_NIEL_ENERGY_MEV * g4.MeV)
            params.SetStepFunctionLightIons(*LIGHT_ION_STEP_FUNCTION)

    return ModularPhysics()


def strip_data_hungry_processes(g4) -> list[str]:
    """Lite mode: remove the processes that need G4EMLOW. Call after ``Initialize()``."""
    table = g4.G4ParticleTable.GetParticleTable()
    removed = []
    for particle, names in LITE_REMOVED_PROCESSES.items():
        manager = table.FindParticle(particle).GetProcessManager()
        for process in list(manager.GetProcessList()):
            if process.GetProcessName() in names:
                manager.RemoveProcess(process)
                removed.append(f"{particle}:{process.GetProcessName()}")
    return removed


#: Charged particles to which lite physics (G4EmStandardPhysics) gives processes but that nothing
#: in a lite run creates: no process of the list makes them (no gamma conversion to muon pairs,
#: no hadronic physics), and no decay emits them. Their tables (bremsstrahlung, pair production,
#: single scattering) are 0.17 s of the 0.22 s the first BeamOn spends building tables.
UNCREATED_PARTICLES = ("mu+", "mu-", "pi+", "pi-", "kaon+", "kaon-", "anti_proton")


def idle_uncreated_particles(g4, started: set[str] | None) -> list[str]:
    """Lite mode: take every process but transportation off the :data:`UNCREATED_PARTICLES`
    the source does not start (``started``: the names of the particles it can start; None:
    unknown, nothing is taken off), so the first BeamOn builds no tables for them. Call after
    ``Initialize()``, before the first BeamOn. Returns the particles made idle: a primary of
    one of them must be refused (:meth:`score4.sim.simulation.Simulation.run` does)."""
    if started is None:
        return []
    table = g4.G4ParticleTable.GetParticleTable()
    idle = []
    for name in UNCREATED_PARTICLES:
        particle = table.FindParticle(name)
        if name in started or particle is None or particle.GetProcessManager() is None:
            continue
        manager = particle.GetProcessManager()
        for process in list(manager.GetProcessList()):
            if process.GetProcessName() != "Transportation":
                manager.RemoveProcess(process)
        idle.append(name)
    return idle


def set_production_cut(g4, cut_mm: float) -> None:
    """Production threshold (as a range) for all particles. Call before ``Initialize()``.

    (``SetDefaultCutValue`` in the physics-list constructor had no effect through the binding;
    the UI command does, measured by the range straggling it restores.)
    """
    g4.G4UImanager.GetUIpointer().ApplyCommand(f"/run/setCut {cut_mm * 1e3:.9g} um")


def drop_unused_parallel_world_region(g4) -> bool:
    """Remove Geant4's ``DefaultRegionForParallelWorld`` from the region store (score4 has no
    parallel worlds). Returns whether it was there.

    Before every ``BeamOn`` Geant4 asks each region whether it belongs to the world
    (``G4RunManagerKernel::CheckRegions`` and ``G4Region::SetWorld`` call
    ``G4Region::BelongsTo``), a recursion that stops at the first volume of that region. For a
    region with no volume in the world it visits every placed volume of the geometry, twice:
    0.27 s per ``BeamOn`` on a 10 cm face of frustum pyramids (1e8 placed volumes), 0.2 ms
    without this region, with the same results (benchmarks/bench_runloop.py). The region object
    stays alive (the run manager kernel keeps a pointer to it); nothing else uses it.
    """
    store = g4.G4RegionStore.GetInstance()
    region = store.GetRegion("DefaultRegionForParallelWorld", False)
    if region is None:
        return False
    store.DeRegister(region)
    return True
