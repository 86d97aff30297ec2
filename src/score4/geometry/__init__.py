"""Geant4 geometry built from score4 descriptions (imports geant4_pybind; used in workers only)."""
