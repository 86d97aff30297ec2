"""Physics lists: ``full`` (EM option4, optional radioactive decay) and ``lite`` (no data)."""

from __future__ import annotations

from .runtime import PhysicsChoice

# Processes that read G4EMLOW data at the first event; lite mode removes them after
# initialisation (found by trial: everything else in option0 runs without data files).
LITE_REMOVED_PROCESSES = {"e-": ("eBrem",), "e+": ("eBrem",), "gamma": ("GammaGeneralProc",)}
# Ions below this kinetic energy get nuclear stopping where the EM constructor supports it
# (option4 does; option0, used by lite mode, ignores it: measured, see runtime.LITE_LACKS).
MAX_NIEL_ENERGY_MEV = 1.0


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
            # After the EM constructor, whose constructor resets the parameters to defaults.
            params = g4.G4EmParameters.Instance()
            params.SetVerbose(0)
            params.SetMaxNIELEnergy(MAX_NIEL_ENERGY_MEV * g4.MeV)

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


def set_production_cut(g4, cut_mm: float) -> None:
    """Production threshold (as a range) for all particles. Call before ``Initialize()``.

    (``SetDefaultCutValue`` in the physics-list constructor had no effect through the binding;
    the UI command does, measured by the range straggling it restores.)
    """
    g4.G4UImanager.GetUIpointer().ApplyCommand(f"/run/setCut {cut_mm * 1e3:.9g} um")
