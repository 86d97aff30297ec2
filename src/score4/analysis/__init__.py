"""Results to physics: templates, background models, normalisation, export, plots (no Geant4)."""
