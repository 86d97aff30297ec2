"""The run record: what a results file's ``/run`` attributes say about the run that made it.

:class:`RunRecord` is written by the engine's merge (:func:`score4.runner.engine.run`) as one HDF5
attribute per field (containers and None as JSON) and read back by
:func:`score4.runner.output.read_results` as the dict ``Results.run``;
:meth:`RunRecord.from_dict` turns that dict into the record again. The fields are documented with
the results-file layout in docs/getting-started.md#the-results-file.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any


@dataclass(kw_only=True)
class RunRecord:
    """The ``/run`` attributes of a results file, in the order they are written.

    Optional fields (None) are left out of the file: ``trim_library_seed`` (runs with a TRIM
    replay), ``n_atoms`` (per-atom histories: ``run.events`` counts atoms),
    ``energy_violations`` and ``energy_max_excess_MeV`` (not with radioactive decay),
    ``untracked_gamma_*`` (lite physics), ``intercepted_ions``, ``reinjected_ions`` and
    ``replay_pushes`` (the heavy-ion TRIM replay), ``implantation`` (chains with
    implantation), ``map_meshes`` (rough layers of height maps). ``normalisation`` is written
    as its own top-level entries (``volumes``, ``source``, ``simulated_decays``, ...:
    :func:`score4.runner.normalisation.run_normalisation`).
    """

    config: dict[str, Any]  # the whole configuration, quantities with units
    patch_maps: dict[str, Any]  # per rough layer: its patch map (score4.surface.patchmap)
    seed: int
    physics_mode: str  # "full" or "lite"
    physics_requested: str  # "auto", "full" or "lite"
    physics_lacks: str  # what lite physics lacks ("" for full)
    missing_data_sets: list[str]
    removed_processes: list[str]  # processes lite physics removed
    trim_library_seed: int | None = None
    rough_shares: dict[str, float]  # per rough layer: the share of its face that is rough
    # per rough layer of height maps: each variant's mesh tolerance (um, 0 exact) and top facets
    map_meshes: dict[str, Any] | None = None
    gdml_files: list[str]  # a GDML world's files (the file and those it includes)
    score4_version: str
    geant4_pybind_version: str
    geant4_version: str
    n_atoms: int | None = None
    n_events: int
    n_chunks: int
    chunk_events: int  # events (atoms) per chunk
    jobs: int  # workers used
    backend: str  # the executor: "local processes (2)", "dask ..."
    resumed_chunks: int  # chunks reused from an interrupted run
    wall_time_s: float
    created_utc: str
    host: str
    geant4_warnings: list[str]  # distinct G4Exceptions with counts
    stuck_tracks_pushed: int
    stuck_events_aborted: int
    energy_check: str
    energy_violations: int | None = None
    energy_max_excess_MeV: float | None = None
    untracked_gamma_energy_MeV: float | None = None
    untracked_gamma_events: int | None = None
    intercepted_ions: int | None = None
    reinjected_ions: int | None = None
    replay_pushes: int | None = None  # stuck replayed ions G4Navigator pushed (GeomNav1002)
    implantation: dict[str, Any] | None = None
    normalisation: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The attributes as written: optional fields left out when None, the normalisation
        entries spread at the end."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "normalisation":
                out.update(value)
            elif value is not None or f.default is not None:
                out[f.name] = value
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RunRecord:
        """The record of a results file's ``run`` dict (``Results.run``); entries that are not
        fields are its normalisation."""
        names = {f.name for f in fields(cls)} - {"normalisation"}
        return cls(
            **{k: v for k, v in data.items() if k in names},
            normalisation={k: v for k, v in data.items() if k not in names},
        )
