"""Run in a spawned process by test_solids (pytest itself never imports Geant4)."""

import numpy as np


def classify(points, grid_kwargs, thickness):
    from score4.geometry.solids import inside_codes, multiunion_solid, tessellated_solid
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.spikes import SpikeGrid
    from score4.surface.triangle_mesh import closed_body

    g4 = import_geant4(resolve_physics("lite"))
    grid = SpikeGrid(**grid_kwargs)
    tess = tessellated_solid(g4, closed_body(grid.top_mesh(), thickness), "tess")
    union, _parts = multiunion_solid(g4, grid, thickness, "union")
    points = np.asarray(points)
    return inside_codes(g4, tess, points).tolist(), inside_codes(g4, union, points).tolist()


def gdml_roundtrip(points, grid_kwargs, thickness, path):
    from score4.geometry.gdml import read_gdml, write_solid_gdml
    from score4.geometry.solids import inside_codes, tessellated_solid
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.surface.spikes import SpikeGrid
    from score4.surface.triangle_mesh import closed_body

    g4 = import_geant4(resolve_physics("lite"))
    mesh = closed_body(SpikeGrid(**grid_kwargs).top_mesh(), thickness)
    solid = tessellated_solid(g4, mesh, "rough")
    write_solid_gdml(g4, solid, path)
    _parser, world = read_gdml(g4, path)
    daughter = world.GetLogicalVolume().GetDaughter(0).GetLogicalVolume()
    back = daughter.GetSolid()
    points = np.asarray(points)
    return (
        inside_codes(g4, solid, points).tolist(),
        inside_codes(g4, back, points).tolist(),
        back.GetEntityType(),
        daughter.GetMaterial().GetName(),
    )
