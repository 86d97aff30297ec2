"""Write the GDML world of docs/geometry.md with pyg4ometry: two_crystals.gdml.

    python examples/gdml/write_two_crystals.py [OUT.gdml]

A vacuum cavity (rotated by 0.2 rad about x) holds two copies of one CaWO4 crystal logical
volume (20 x 20 x 40 mm, the second turned by 0.5 rad about z) 30 mm apart, and a copper disk
(r = 15 mm, 4 mm thick) 2 mm above the first crystal.
"""

from __future__ import annotations

import math
import sys

import pyg4ometry as pg


def main(out: str = "two_crystals.gdml") -> None:
    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 300, 300, 300, reg), "G4_Galactic", "World", reg
    )
    cavity = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("cavity_s", 150, 150, 150, reg), "G4_Galactic", "Cavity", reg
    )
    pg.geant4.PhysicalVolume([0.2, 0, 0], [0, 0, 10], cavity, "cavity", world, reg)
    crystal = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("crystal_s", 20, 20, 40, reg), "G4_CALCIUM_TUNGSTATE", "Crystal", reg
    )
    pg.geant4.PhysicalVolume(
        [0, 0, 0], [-15, 0, 0], crystal, "crystal_a", cavity, reg, copyNumber=0
    )
    pg.geant4.PhysicalVolume(
        [0, 0, 0.5], [15, 0, 0], crystal, "crystal_b", cavity, reg, copyNumber=1
    )
    disk = pg.geant4.LogicalVolume(
        pg.geant4.solid.Tubs("disk_s", 0, 15, 4, 0, 2 * math.pi, reg), "G4_Cu", "Disk", reg
    )
    pg.geant4.PhysicalVolume([0, 0, 0], [-15, 0, 24], disk, "disk", cavity, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(out)


if __name__ == "__main__":
    main(*sys.argv[1:])
