"""Geant4 geometry built from score4 descriptions, and the volume model of a GDML world.

Most modules build Geant4 volumes and take the ``geant4_pybind`` module as ``g4``: they run in
worker processes. ``volumes``, ``gdml_files``, ``listing`` and ``walls`` are numpy and run in the
parent. docs/architecture.md draws the boundary; the import contracts of pyproject.toml
(``lint-imports``) enforce it.
"""
