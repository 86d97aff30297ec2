"""What a user writes: run configuration, schema, units, limits, material names (no Geant4)."""
