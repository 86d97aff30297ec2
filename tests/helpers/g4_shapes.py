"""Run in a spawned process by test_shapes_g4 (pytest itself never imports Geant4)."""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2 * math.pi
N_TESS = 360  # facets around a tessellated cylinder


def _tessellated_cylinder(g4, r: float, dz: float, n: int):
    solid = g4.G4TessellatedSolid("tess_cyl")
    phi = np.linspace(0, TWO_PI, n + 1)[:-1]
    ring = [(r * math.cos(p), r * math.sin(p)) for p in phi]
    v = g4.G4ThreeVector
    absolute = g4.G4FacetVertexType.ABSOLUTE
    for i in range(n):
        (x0, y0), (x1, y1) = ring[i], ring[(i + 1) % n]
        solid.AddFacet(
            g4.G4QuadrangularFacet(
                v(x0, y0, -dz), v(x1, y1, -dz), v(x1, y1, dz), v(x0, y0, dz), absolute
            )
        )
        solid.AddFacet(g4.G4TriangularFacet(v(0, 0, dz), v(x0, y0, dz), v(x1, y1, dz), absolute))
        solid.AddFacet(g4.G4TriangularFacet(v(0, 0, -dz), v(x1, y1, -dz), v(x0, y0, -dz), absolute))
    solid.SetSolidClosed(True)
    return solid


def make_direct(g4) -> dict:
    """The solids built with their constructors (names match test_shapes_g4.HAND)."""
    rot = g4.G4RotationMatrix()
    rot.rotateX(0.4)
    rot.rotateZ(0.3)
    keep = {
        "box": g4.G4Box("box", 10, 20, 30),
        "trd": g4.G4Trd("trd", 10, 5, 20, 8, 15),
        "trap": g4.G4Trap("trap", 30, 0.1, 0.2, 20, 10, 15, 0.1, 10, 5, 7.5, 0.1),
        "tubs": g4.G4Tubs("tubs", 5, 35, 10, 0.3, 4.0),
        "tubs_full": g4.G4Tubs("tubs_full", 0, 35, 10, 0, TWO_PI),
        "cons": g4.G4Cons("cons", 2, 10, 5, 20, 15, 0.5, 5.0),
        "sphere": g4.G4Sphere("sphere", 5, 10, 0.2, 2.0, 0.3, 1.0),
        "hemisphere": g4.G4Sphere("hemisphere", 3, 10, 0, TWO_PI, 0, 0.5 * math.pi),
        "orb": g4.G4Orb("orb", 12),
    }
    half1 = g4.G4Tubs("half1", 0, 35, 10, 0, math.pi)
    half2 = g4.G4Tubs("half2", 0, 35, 10, math.pi, math.pi)
    keep["tubs_as_union"] = g4.G4UnionSolid("tubs_as_union", half1, half2)
    hole = g4.G4Tubs("hole", 0, 4, 40, 0, TWO_PI)
    keep["box_minus_tubs"] = g4.G4SubtractionSolid(
        "box_minus_tubs", keep["box"], hole, rot, g4.G4ThreeVector(2, 3, 1)
    )
    keep["tessellated"] = _tessellated_cylinder(g4, 35, 10, N_TESS)
    keep["torus"] = g4.G4Torus("torus", 0, 5, 20, 0, TWO_PI)
    keep["_parts"] = (half1, half2, hole, rot)
    return keep


def measure(gdml_path: str, gdml_names: list[str], requests: dict) -> dict:
    """For each requested solid: Geant4's area and volume, the shape read from it, Inside codes
    and SurfaceNormal at the given points; LiveSolidShape figures for the live-only ones."""
    from score4.geometry.gdml import read_gdml
    from score4.geometry.solid_shapes import LiveSolidShape, shape_from_g4_solid
    from score4.geometry.solids import inside_codes
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    _parser, _world = read_gdml(g4, gdml_path)
    solids = make_direct(g4)
    store = g4.G4SolidStore.GetInstance()
    for name in gdml_names:
        solids[name] = store.GetSolid(name)
    out = {}
    for name, req in requests.items():
        solid = solids[req.get("solid", name)]
        shape = LiveSolidShape(solid) if req.get("live") else shape_from_g4_solid(solid)
        if isinstance(shape, LiveSolidShape) and "max_lines" in req:  # one round of 10^5
            shape = LiveSolidShape(solid, max_area_lines=req["max_lines"])
        res: dict = {
            "type": solid.GetEntityType(),
            "g4_area": solid.GetSurfaceArea(),
            "g4_volume": solid.GetCubicVolume(),
            "shape_type": shape.kind,
        }
        if isinstance(shape, LiveSolidShape):
            rng = np.random.default_rng(5)
            s = shape.sample_surface(rng, req.get("n_live", 2000))
            res["live_area"], res["live_area_error"] = shape.area, shape.area_error
            res["live_codes"] = inside_codes(g4, solid, s.position).tolist()
            res["live_positions"] = s.position.tolist()
        else:
            res["shape"] = shape.to_dict()
            res["face_areas"] = shape.face_areas
        pts = np.asarray(req.get("points", []), float).reshape(-1, 3)
        res["codes"] = inside_codes(g4, solid, pts).tolist()
        at = np.asarray(req.get("normals_at", []), float).reshape(-1, 3)
        normals = [solid.SurfaceNormal(g4.G4ThreeVector(*p)) for p in at]
        res["normals"] = [[n.x, n.y, n.z] for n in normals]
        out[name] = res
    return out


def placement_check(local_points: list) -> list:
    """A box placed rotated and moved in a world: Transform.from_g4 of the placement maps
    local points to world points; returns Geant4's local coordinates of those world points."""
    from score4.shapes import Transform
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    nist = g4.G4NistManager.Instance()
    world_s = g4.G4Box("w", 100, 100, 100)
    world_lv = g4.G4LogicalVolume(world_s, nist.FindOrBuildMaterial("G4_Galactic"), "w")
    world = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "w", None, False, 0, False)
    box_s = g4.G4Box("b", 10, 20, 30)
    box_lv = g4.G4LogicalVolume(box_s, nist.FindOrBuildMaterial("G4_Si"), "b")
    rot = g4.G4RotationMatrix()
    rot.rotateX(0.4)
    rot.rotateY(-0.7)
    pv = g4.G4PVPlacement(rot, g4.G4ThreeVector(5, -6, 7), box_lv, "b", world_lv, False, 0, False)
    t = Transform.from_g4(pv.GetObjectRotationValue(), pv.GetTranslation())
    nav = g4.G4Navigator()
    nav.SetWorldVolume(world)
    out = []
    for q in t.apply(np.asarray(local_points, float)):
        p = g4.G4ThreeVector(*q)
        found = nav.LocateGlobalPointAndSetup(p)
        loc = nav.GetGlobalToLocalTransform().TransformPoint(p)
        out.append([found.GetName(), loc.x, loc.y, loc.z])
    _keep = (world_s, world_lv, box_s, box_lv, rot, pv)
    return out
