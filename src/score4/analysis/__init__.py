"""Results to physics: templates, models, response, normalisation, export, plots (no Geant4)."""
