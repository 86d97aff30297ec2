"""Run in a spawned process by test_solids (pytest itself never imports Geant4)."""

import numpy as np


def classify(points, grid_kwargs, thickness):
    from score4.sim.runtime import import_geant4, resolve_physics
    from score4.geometry.solids import inside_codes, multiunion_solid, tessellated_solid
    from score4.surface.mesh import closed_body
    from score4.surface.spikes import SpikeGrid

    g4 = import_geant4(resolve_physics("lite"))
    grid = SpikeGrid(**grid_kwargs)
    tess = tessellated_solid(g4, closed_body(grid.top_mesh(), thickness), "tess")
    union, parts = multiunion_solid(g4, grid, thickness, "union")
    points = np.asarray(points)
    return inside_codes(g4, tess, points).tolist(), inside_codes(g4, union, points).tolist()
