"""The resolved world: rough faces, targets, clearance, GDML files, listing (no Geant4)."""
