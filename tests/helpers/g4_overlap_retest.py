"""Run in a spawned process by test_facet_split: Geant4's overlap reports between two bent patch
bodies of a cone (neighbouring rings), re-tested exactly (score4.geometry.check)."""

from pathlib import Path

import numpy as np


def _world(g4, layer, shift: float):
    """A vacuum box holding a body of ring 0 and one of ring 1 at azimuth 0 (the target at the
    origin; the layer places its cells at other azimuths, the row gap between rings is the
    same); ring 1's moved by ``shift`` (mm) along -z, towards ring 0."""
    from score4.geometry.solids import tessellated_solid
    from score4.surface.triangle_mesh import TriangleMesh

    vacuum = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Galactic")
    box = g4.G4Box("world", 20.0, 20.0, 20.0)
    world_lv = g4.G4LogicalVolume(box, vacuum, "world")
    world = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "world", None, False, 0)
    keep = [box, world_lv, world]
    lay = layer.ring_layout
    for j in (0, 1):
        bent = layer.bent(0, j)
        solid = tessellated_solid(g4, TriangleMesh(bent.vertices, bent.faces), f"body{j}")
        lv = g4.G4LogicalVolume(solid, vacuum, f"body{j}")
        z = lay.ring_z(j) - (shift if j == 1 else 0.0)
        pv = g4.G4PVPlacement(None, g4.G4ThreeVector(0, 0, z), lv, f"body{j}", world_lv, False, j)
        keep += [solid, lv, pv]
    return world, keep


def check_two_rings(layer, log: str, shift: float, points: int):
    """``check_placements`` (with the exact re-test) on the two bodies: (overlaps, false
    reports)."""
    from score4.geometry.check import check_placements
    from score4.sim.geometry_check import log_reader
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    with redirect_native_output(Path(log)):
        world, _keep = _world(g4, layer, shift)
        report = check_placements(world, points, read_log=log_reader(Path(log)))
    return report.overlaps, report.false_reports


def retest_two_reports(layer, shift: float):
    """Two reports of ring 1's body inside ring 0's, as Geant4 prints them (six significant
    digits, ring 0's frame): a point of ring 1's end wall facing ring 0, with the bodies as
    placed (in the row gap: outside ring 0's body by the gap) and with ring 1's moved ``shift``
    (mm) towards ring 0 (inside it by ``shift`` less the gap). Returns what
    :func:`retest_report` says of each."""
    from score4.geometry.check import retest_report
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    lay = layer.ring_layout
    py = lay.patch_size[1]
    # ring 1's patch-local end facing ring 0 (y = -py/2), half-way up the slab, bent
    local = np.array([[0.0, -py / 2, -0.5 * layer.base_thickness]])
    on_wall = lay.bend(local, 1, layer.base_thickness + layer.lift)[0]
    out = []
    for move in (0.0, shift):
        world, keep = _world(g4, layer, move)
        lv = world.GetLogicalVolume()
        body0, body1 = lv.GetDaughter(0), lv.GetDaughter(1)
        # ring 1's frame -> the world -> ring 0's frame
        point = on_wall + np.array([0.0, 0.0, lay.ring_z(1) - move - lay.ring_z(0)])
        printed = np.array([float(f"{c:.6g}") for c in point])
        out.append(retest_report(body1, body0, printed, 0.0, {}))
        del keep
    return out
