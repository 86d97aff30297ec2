"""Run in a spawned process by test_surface_cli (pytest itself never imports Geant4).

``score4 surface export --gdml`` imports Geant4 into the process that runs it, so the command
itself runs here, then the file is read back with Geant4's GDML reader.
"""

import numpy as np


def export_and_classify(surface_file, gdml_path, extra_args, points):
    """Run the export command, read the GDML back, classify ``points`` with the read solid.

    Returns (exit status, solid type, material name, bounding limits lo, hi, inside codes).
    """
    from score4.cli.main import main

    status = main(["surface", "export", str(surface_file), "--gdml", str(gdml_path), *extra_args])
    if status != 0:
        return status, None, None, None, None, None
    from score4.geometry.gdml import read_gdml
    from score4.geometry.solids import inside_codes
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))  # already imported by the command: same module
    _parser, world = read_gdml(g4, gdml_path)
    daughter = world.GetLogicalVolume().GetDaughter(0).GetLogicalVolume()
    solid = daughter.GetSolid()
    lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
    solid.BoundingLimits(lo, hi)
    codes = inside_codes(g4, solid, np.asarray(points, dtype=float)).tolist()
    return (
        status,
        solid.GetEntityType(),
        daughter.GetMaterial().GetName(),
        [lo.x, lo.y, lo.z],
        [hi.x, hi.y, hi.z],
        codes,
    )
