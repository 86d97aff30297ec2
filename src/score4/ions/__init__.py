"""Ions in matter: target compositions, TRIM (lunasrim) reference data and trajectory libraries.

Pure numpy and lunasrim; nothing here imports Geant4 (the Geant4 side lives in ``score4.sim``).
"""
