"""Write a LEGEND BEGe with its detector metadata as GDML: bege.gdml.

    python examples/rough_hpge/write_bege.py [OUT.gdml]

legend-pygeom-hpges builds the detector (``make_hpge``) from the metadata below, and
legend-pygeom-tools writes it with the metadata in the file's ``<userinfo>`` (as LEGEND's
geometries are written), so that score4 knows the detector's surfaces: the groups ``pplus``
(the p+ contact, r < 7.5 mm), ``passive`` (the ring out to the groove and the groove) and
``nplus``. The contact and the ring, one face ``seg_0`` of the polycone, become the faces
``seg_0a`` and ``seg_0b``.
"""

from __future__ import annotations

import sys

BEGE = {
    "name": "B00000T",
    "type": "bege",
    "production": {"enrichment": 0.88},
    "geometry": {
        "height_in_mm": 30.0,
        "radius_in_mm": 35.0,
        "groove": {"depth_in_mm": 2.0, "radius_in_mm": {"outer": 13.0, "inner": 10.0}},
        "pp_contact": {"radius_in_mm": 7.5, "depth_in_mm": 0.0},
        "taper": {
            "top": {"angle_in_deg": 45.0, "height_in_mm": 2.0},
            "bottom": {"angle_in_deg": 45.0, "height_in_mm": 2.0},
        },
    },
}


def main(out: str = "bege.gdml") -> None:
    import pyg4ometry as pg
    import pygeomtools
    from pygeomhpges import make_hpge

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    bege = make_hpge(BEGE, registry=reg)
    pv = pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], bege, "bege", world, reg)
    pv.set_pygeom_active_detector(pygeomtools.RemageDetectorInfo("germanium", 1, BEGE))
    reg.setWorld(world.name)
    pygeomtools.write_pygeom(reg, out)


if __name__ == "__main__":
    main(*sys.argv[1:])
