"""Run as a script by test_limits (pytest itself never imports Geant4): build one G4Box of full
edge ``argv[1]`` mm and print Geant4's NIST material names; a too small box aborts the process
with a fatal G4Exception."""

import sys

from score4.inputs.materials import nist_material_names
from score4.sim.runtime import import_geant4, resolve_physics

g4 = import_geant4(resolve_physics("lite"))
half = float(sys.argv[1]) / 2
box = g4.G4Box("box", half, half, half)
print("BUILT", box.GetCubicVolume() > 0, flush=True)
print("NIST", "|".join(nist_material_names(g4)), flush=True)
