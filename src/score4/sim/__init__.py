"""The run engine and the Geant4 side of score4: runtime, physics, scoring, workers.

The parent process runs ``engine``, ``dask_backend``, ``seeds``, ``conservation`` and
``run_record`` (and imports ``worker`` for its chunk types); it never imports geant4_pybind.
Worker processes import it, through :func:`score4.sim.runtime.import_geant4` only, and run the
rest. docs/architecture.md draws the boundary; the import contracts of pyproject.toml
(``lint-imports``) enforce it.
"""
