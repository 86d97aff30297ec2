"""Write the GDML world of the rough cylindrical crystal example with pyg4ometry: crystal.gdml.

    python examples/curved/write_crystal.py [OUT.gdml]

A CaWO4 cylinder (radius 20 mm, 20 mm long, a CRESST-like crystal) in vacuum, as a G4Tubs: its
side wall is the face `outer` of po210_wall.yaml (rough) and po210_wall_flat.yaml (flat).
"""

from __future__ import annotations

import math
import sys

import pyg4ometry as pg


def main(out: str = "crystal.gdml") -> None:
    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    crystal = pg.geant4.LogicalVolume(
        pg.geant4.solid.Tubs("crystal_s", 0, 20, 20, 0, 2 * math.pi, reg),
        "G4_CALCIUM_TUNGSTATE",
        "Crystal",
        reg,
    )
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], crystal, "crystal", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(out)


if __name__ == "__main__":
    main(*sys.argv[1:])
