"""Running a configuration in the parent: engine, Dask, seeds, conservation, results files.

Nothing here imports Geant4; the chunks run in worker processes (:mod:`score4.sim`).
"""
