"""What a user writes: the run configuration, its materials and its response section (no Geant4)."""
