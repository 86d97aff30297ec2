"""What a user writes: the run configuration, materials, detector response (no Geant4)."""
