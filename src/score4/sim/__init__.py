"""Geant4 side of score4: runtime, physics, scoring, heavy-ion replay, range runs, the worker.

Only :mod:`score4.sim` and :mod:`score4.geometry` import geant4_pybind, and only inside
worker processes: the process that reads the configuration and writes results (:mod:`score4.runner`)
never does.
"""
