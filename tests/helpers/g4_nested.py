"""Run in a spawned process by test_tiling_nested: place a patch map in nested groups and read
back, from Geant4's own volume tree, where every cell box ended up."""

from __future__ import annotations

import numpy as np


def nested_cells(variants: list, cell: tuple, max_daughters: int, budget: int) -> dict:
    """Place ``variants`` (ny x nx variant ids) with :func:`place_nested`; walk the tree.

    Returns the cell boxes found (variant, centre x, centre y, z) in tree order, the most
    daughters any mother holds, the number of levels and the number of logical volumes.
    """
    from score4.geometry.tiling import grouping_plan, place_nested
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    ids = np.asarray(variants)
    ny, nx = ids.shape
    px, py, t = cell
    vacuum = g4.G4NistManager.Instance().FindOrBuildMaterial("G4_Galactic")
    with redirect_native_output(None):
        env_solid = g4.G4Box("env", nx * px / 2, ny * py / 2, t / 2)
        env = g4.G4LogicalVolume(env_solid, vacuum, "env")
        boxes = [g4.G4Box(f"c{k}", px / 2, py / 2, t / 2) for k in range(int(ids.max()) + 1)]
        cells = [g4.G4LogicalVolume(b, vacuum, f"c{k}") for k, b in enumerate(boxes)]
        keep = place_nested(g4, ids, cells, cell, env, vacuum, "L", max_daughters, budget)
    which = {id(lv): k for k, lv in enumerate(cells)}
    names = {lv.GetName(): k for k, lv in enumerate(cells)}
    found, most = [], 0

    def walk(lv, x: float, y: float, z: float) -> None:
        nonlocal most
        n = lv.GetNoDaughters()
        most = max(most, n)
        for d in range(n):
            pv = lv.GetDaughter(d)
            tr = pv.GetTranslation()
            child = pv.GetLogicalVolume()
            cx, cy, cz = x + tr.x, y + tr.y, z + tr.z
            k = names.get(child.GetName())
            if k is not None:
                found.append((k, cx, cy, cz))
            else:
                walk(child, cx, cy, cz)

    walk(env, 0.0, 0.0, 0.0)
    assert which  # the cell volumes are the ones passed in
    return {
        "cells": found,
        "most_daughters": most,
        "levels": [g for g, _, _ in grouping_plan(ids, max_daughters, budget)],
        "logical_volumes": sum(type(k).__name__ == "G4LogicalVolume" for k in keep),
        "regions": sum(type(k).__name__ == "G4Region" for k in keep),
    }
