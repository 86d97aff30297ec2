"""A GDML world of boolean solids for tests/test_boolean_rough.py, written by pyg4ometry and
legend-pygeom-tools at test time:

* ``cutbox``: a copper box (20 mm) less a tube (r 5 mm) through it along z;
* ``ppc``: LEGEND's P00664B, a p-type point-contact detector whose polycone is cut by a box
  (legend-pygeom-hpges builds it; its metadata go into the file's userinfo);
* ``stack``: a copper disk (r 10 mm, 10 mm) with a tube (r 7 mm, 10 mm) on top, a union.
"""

from __future__ import annotations

import math
from pathlib import Path

#: P00664B: a PPC with a cut plane at x = 30 mm (the part beyond it removed).
PPC = {
    "name": "P00664B",
    "type": "ppc",
    "production": {"enrichment": 0.88},
    "geometry": {
        "height_in_mm": 30.0,
        "radius_in_mm": 35.0,
        "pp_contact": {"radius_in_mm": 2.0, "depth_in_mm": 0.0},
        "taper": {
            "top": {"angle_in_deg": 45.0, "height_in_mm": 2.0},
            "bottom": {"angle_in_deg": 45.0, "height_in_mm": 2.0},
        },
        "extra": {"crack": {"radius_in_mm": 30.0, "angle_in_deg": 0.0}},
    },
}
CUTBOX_POSITION = (0.0, 0.0, 0.0)
PPC_POSITION = (0.0, 0.0, 60.0)
STACK_POSITION = (0.0, -60.0, 0.0)


def write_world(path: Path) -> Path:
    import pyg4ometry as pg
    import pygeomtools
    from pygeomhpges import make_hpge

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 300, 300, 300, reg), "G4_Galactic", "W", reg)
    box = s.Box("cut_a", 20, 20, 20, reg)
    hole = s.Tubs("cut_b", 0, 5, 40, 0, 2 * math.pi, reg)
    cut = s.Subtraction("cutbox_s", box, hole, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "cutbox_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(CUTBOX_POSITION), lv, "cutbox", world, reg)
    disk = s.Tubs("stack_a", 0, 10, 10, 0, 2 * math.pi, reg)
    post = s.Tubs("stack_b", 0, 7, 10, 0, 2 * math.pi, reg)
    stack = s.Union("stack_s", disk, post, [[0, 0, 0], [0, 0, 10]], reg)
    lv = pg.geant4.LogicalVolume(stack, "G4_Cu", "stack_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(STACK_POSITION), lv, "stack", world, reg)
    ppc = make_hpge(PPC, registry=reg, allow_cylindrical_asymmetry=True)
    pv = pg.geant4.PhysicalVolume([0, 0, 0], list(PPC_POSITION), ppc, "ppc", world, reg)
    pv.set_pygeom_active_detector(pygeomtools.RemageDetectorInfo("germanium", 1, PPC))
    reg.setWorld(world.name)
    pygeomtools.write_pygeom(reg, str(path))
    return path
