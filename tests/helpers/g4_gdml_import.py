"""Run in a spawned process by test_gdml_import (pytest itself never imports Geant4)."""

from __future__ import annotations


def inspect_gdml(path: str, solid_points: list, world_points: list) -> dict:
    """Read ``path`` with score4's reader and report what Geant4 made of it, as plain values.

    ``solid_points`` are classified by the daughter solid (its own frame), ``world_points`` by a
    navigator over the whole world (so the placement counts).
    """
    import numpy as np

    from score4.geometry.gdml import read_gdml
    from score4.geometry.solids import inside_codes
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    _parser, world = read_gdml(g4, path)  # the parser must outlive the volumes it made
    world_lv = world.GetLogicalVolume()
    box = world_lv.GetSolid()
    pv = world_lv.GetDaughter(0)
    lv = pv.GetLogicalVolume()
    solid = lv.GetSolid()
    lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
    solid.BoundingLimits(lo, hi)
    t = pv.GetTranslation()
    navigator = g4.G4Navigator()
    navigator.SetWorldVolume(world)
    located = [navigator.LocateGlobalPointAndSetup(g4.G4ThreeVector(*p)) for p in world_points]
    n = solid.GetNumberOfFacets()
    return {
        "n_daughters": world_lv.GetNoDaughters(),
        "world_half": [box.GetXHalfLength(), box.GetYHalfLength(), box.GetZHalfLength()],
        "world_material": world_lv.GetMaterial().GetName(),
        "type": solid.GetEntityType(),
        "material": lv.GetMaterial().GetName(),
        "pv_name": pv.GetName(),
        "translation": [t.x, t.y, t.z],
        "n_facets": n,
        "facet_vertices": [solid.GetFacet(i).GetNumberOfVertices() for i in range(n)],
        "volume": solid.GetCubicVolume(),
        "area": solid.GetSurfaceArea(),
        "limits": [[lo.x, lo.y, lo.z], [hi.x, hi.y, hi.z]],
        "inside": inside_codes(g4, solid, np.asarray(solid_points, dtype=float)).tolist(),
        "located": [v.GetName() if v is not None else None for v in located],
    }
