"""Run in a spawned process by test_surface_cli (pytest itself never imports Geant4).

``score4 surface export --gdml`` writes the file from a process of its own; here the file is
read back with Geant4's GDML reader, one file per process (Geant4's stores hold volumes by name).
"""

import numpy as np


def classify(gdml_path, points):
    """Read the GDML file back, classify ``points`` with the read solid.

    Returns (solid type, material name, bounding limits lo, hi, inside codes).
    """
    from score4.geometry.gdml import read_gdml
    from score4.geometry.solids import inside_codes
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    _parser, world = read_gdml(g4, gdml_path)
    daughter = world.GetLogicalVolume().GetDaughter(0).GetLogicalVolume()
    solid = daughter.GetSolid()
    lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
    solid.BoundingLimits(lo, hi)
    codes = inside_codes(g4, solid, np.asarray(points, dtype=float)).tolist()
    return (
        solid.GetEntityType(),
        daughter.GetMaterial().GetName(),
        [lo.x, lo.y, lo.z],
        [hi.x, hi.y, hi.z],
        codes,
    )
