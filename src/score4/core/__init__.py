"""The base layer every package builds on: units, schema pieces, limits, strict YAML (no Geant4)."""
