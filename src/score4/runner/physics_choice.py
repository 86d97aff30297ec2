"""The physics a run uses (``full`` or ``lite``, with or without radioactive decay), chosen from
the request and the Geant4 data sets installed, and the data-set variables Geant4 reads, set
before geant4_pybind is imported (:func:`score4.sim.runtime.import_geant4`). No Geant4 here: the
parent makes the choice when it plans a run."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

from score4.errors import PhysicsUnavailableError
from score4.files import cache_dir
from score4.runner import datasets

# What lite physics cannot do, said once to the user and stored with every run.
LITE_LACKS = (
    "standard EM (option0) instead of option4; electrons and positrons are tracked "
    "(ionisation, multiple scattering) without bremsstrahlung; gammas and X-rays are not "
    "tracked (Geant4 has no data-free photoelectric model), their energy is counted "
    "(events/untracked_gamma_energy); no fluorescence/Auger; no radioactive decay"
)


@dataclass(frozen=True)
class PhysicsChoice:
    """The physics a run uses, decided from the request and the installed data."""

    mode: str  # "full" or "lite"
    requested: str  # "auto", "full" or "lite"
    decay: bool  # radioactive decay physics registered
    lacks: str  # "" for full physics
    missing_data: tuple[str, ...]  # data sets that full physics would need and are missing

    @property
    def warning(self) -> str | None:
        if self.mode == "lite" and self.requested == "auto":
            missing = ", ".join(self.missing_data) or "none"
            return (
                f"physics: lite mode (Geant4 data sets missing: {missing}): alpha, ion and "
                "electron transport, gammas not tracked, no radioactive decay; 'score4 summary' "
                "of the results lists what else it lacks; 'score4 data install' gives full physics"
            )
        return None


def resolve_physics(requested: str, needs_decay: bool = False) -> PhysicsChoice:
    """Pick ``full`` or ``lite`` physics for ``requested`` in {"auto", "full", "lite"}."""
    statuses = datasets.status()
    full_missing = tuple(datasets.missing_for("full", statuses))
    decay_missing = tuple(datasets.missing_for("decay", statuses))
    if needs_decay:
        if requested == "lite" or decay_missing or full_missing:
            missing = ", ".join(sorted(set(full_missing + decay_missing))) or "none"
            raise PhysicsUnavailableError(
                "physics: this source needs Geant4 radioactive decay, which needs the data sets "
                "G4EMLOW, G4ENSDFSTATE, PhotonEvaporation and RadioactiveDecay (missing: "
                f"{missing}); lite mode cannot do decays. Run 'score4 data install' on a machine "
                "with internet, or use source.decay instead of source.nuclide (score4's own decay "
                "sampling, e.g. decay: Pb210), which needs no data"
            )
        return PhysicsChoice("full", requested, True, "", ())
    if requested == "full" and full_missing:
        raise PhysicsUnavailableError(
            f"physics.mode: 'full' needs the Geant4 data sets {', '.join(full_missing)}, which are "
            f"not installed; run 'score4 data install', or use mode 'lite' ({LITE_LACKS})"
        )
    if requested == "lite" or full_missing:
        return PhysicsChoice("lite", requested, False, LITE_LACKS, full_missing)
    return PhysicsChoice("full", requested, False, "", ())


def lite_stub_dir() -> Path:
    """A folder with the empty stand-ins that let Geant4 start without data
    (docs/geant4-facts.md)."""
    base = cache_dir("geant4-lite-stub")
    (base / "G4ENSDFSTATE3.0").mkdir(parents=True, exist_ok=True)
    (base / "G4ENSDFSTATE3.0" / "ENSDFSTATE.dat").touch()
    (base / "PhotonEvaporation6.1.2").mkdir(parents=True, exist_ok=True)
    (base / "G4EMLOW8.8").mkdir(parents=True, exist_ok=True)
    return base


def prepare_environment(choice: PhysicsChoice) -> None:
    """Set the data-set variables Geant4 reads, before geant4_pybind is imported."""
    if "geant4_pybind" in sys.modules:
        return
    os.environ.update(datasets.geant4_env(datasets.status()))
    if choice.mode == "lite":
        stub = lite_stub_dir()
        # The ion table reads ENSDFSTATE and de-excitation checks PhotonEvaporation at start-up;
        # empty stand-ins satisfy both when the real sets are absent.
        os.environ.setdefault("G4ENSDFSTATEDATA", str(stub / "G4ENSDFSTATE3.0"))
        os.environ.setdefault("G4LEVELGAMMADATA", str(stub / "PhotonEvaporation6.1.2"))
        # G4EmParameters warns (twice, G4Exception em0003) when no G4LEDATA folder exists; lite
        # physics reads nothing from it
        os.environ.setdefault("G4LEDATA", str(stub / "G4EMLOW8.8"))
        os.environ.setdefault("GEANT4_DATA_DIR", str(stub))
    else:
        os.environ.setdefault("GEANT4_DATA_DIR", str(datasets.default_data_dir()))
