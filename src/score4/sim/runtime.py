"""Importing geant4_pybind safely, choosing the physics mode, capturing Geant4's console output.

geant4_pybind runs a data-set check at import: without ``GEANT4_DATA_DIR`` it asks on stdin
or, with ``CI=true``, downloads from CERN. score4 always decides the data locations itself
before the import, so neither can happen.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from dataclasses import dataclass
from pathlib import Path

from ..errors import PhysicsUnavailableError

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
    from score4.runner import datasets

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
    from ..files import cache_dir

    base = cache_dir("geant4-lite-stub")
    (base / "G4ENSDFSTATE3.0").mkdir(parents=True, exist_ok=True)
    (base / "G4ENSDFSTATE3.0" / "ENSDFSTATE.dat").touch()
    (base / "PhotonEvaporation6.1.2").mkdir(parents=True, exist_ok=True)
    (base / "G4EMLOW8.8").mkdir(parents=True, exist_ok=True)
    return base


def prepare_environment(choice: PhysicsChoice) -> None:
    """Set the data-set variables Geant4 reads, before geant4_pybind is imported."""
    from score4.runner import datasets

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


def import_geant4(choice: PhysicsChoice):
    """Import geant4_pybind with the data locations fixed by ``choice``; return the module."""
    prepare_environment(choice)
    import geant4_pybind

    return geant4_pybind


@contextlib.contextmanager
def redirect_native_output(log_path: Path | None):
    """Send everything written to file descriptors 1 and 2 (Geant4's G4cout/G4cerr) to a log.

    geant4_pybind does not bind G4UIsession, so the console cannot be captured inside Geant4;
    redirecting the descriptors is the reliable way. Yields a text stream on the original
    stderr for progress messages. With ``log_path=None`` nothing is redirected.
    """
    if log_path is None:
        yield sys.stderr
        return
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    console = os.fdopen(os.dup(saved[1]), "w", buffering=1)
    with open(log_path, "ab") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            yield console
        finally:
            libc.fflush(None)
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            console.close()


def geant4_version(g4) -> str:
    """ "11.4.1"-style version of the Geant4 inside geant4_pybind."""
    number = int(g4.G4VERSION_NUMBER)
    return f"{number // 100}.{(number // 10) % 10}.{number % 10}"
