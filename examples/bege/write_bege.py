"""Write a LEGEND BEGe detector in a vacuum world as GDML with legend-pygeom-hpges: bege.gdml.

    python examples/bege/write_bege.py [OUT.gdml] [--metadata]

The detector is built by legend-pygeom-hpges (``make_hpge``) from the metadata below (a BEGe of
70 mm diameter and 30 mm height with a groove around its p+ contact, the layout of LEGEND's
detector database), placed at the origin of a vacuum world and written by pyg4ometry. The same
metadata give LEGEND's tools (reboost, revertex) the detector's surfaces: ``nplus``, ``pplus``
and ``passive``.

With ``--metadata`` legend-pygeom-tools writes the file instead, with the metadata in its
``<userinfo>`` (as LEGEND's geometries are written), so that score4 knows the detector's
surfaces too: the groups ``pplus`` (the p+ contact, r < 7.5 mm), ``passive`` (the ring out to
the groove and the groove) and ``nplus``. The contact and the ring, one face ``seg_0`` of the
polycone, then become the faces ``seg_0a`` and ``seg_0b`` (``seg_0`` names both), so a source
on ``seg_0`` draws other points: examples/rough_hpge writes with ``--metadata``, the examples
here without.
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


def main(out: str = "bege.gdml", metadata: bool = False, detector: dict | None = None) -> None:
    """Write the BEGe (``detector``: other metadata of the same layout, default ``BEGE``)."""
    import pyg4ometry as pg
    from pygeomhpges import make_hpge

    detector = detector or BEGE
    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    bege = make_hpge(detector, registry=reg)
    pv = pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], bege, "bege", world, reg)
    reg.setWorld(world.name)
    if metadata:
        import pygeomtools

        pv.set_pygeom_active_detector(pygeomtools.RemageDetectorInfo("germanium", 1, detector))
        pygeomtools.write_pygeom(reg, out)
        return
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(out)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(*[a for a in args if a != "--metadata"], metadata="--metadata" in args)
