"""Write module.gdml: a cryogenic detector module, with pyg4ometry.

A CaWO4 crystal (30 x 30 x 20 mm, 109 g) stands in a square copper frame whose window leaves a
2 mm gap to its four sides; eight copper clamps (two per side, above and below, each reaching
3 mm over the crystal and 1 mm onto the frame) hold it; a copper housing with 3 mm walls
closes the module. Frame and housing are boolean solids (a box less a box), the clamps are eight
placements of one logical volume (``clamp``; ``clamp_0`` ... ``clamp_7``), turned by 0, 90, 180
and 270 degrees about z. All in vacuum.

    python examples/detector_module/write_module.py [OUT.gdml]

(pyg4ometry is in score4's test extra: pip install -e '.[test]'.)
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import pyg4ometry as pg

CRYSTAL = (30.0, 30.0, 20.0)  # full edges, mm
WINDOW = 34.0  # frame window (2 mm gap to the crystal's sides)
FRAME = (50.0, 50.0, 20.0)
CLAMP = (6.0, 4.0, 1.5)  # across the edge, along it, thickness
HOUSING, WALL = (64.0, 64.0, 40.0), 3.0


def module(path: Path) -> Path:
    reg = pg.geant4.Registry()
    box = pg.geant4.solid.Box
    world = pg.geant4.LogicalVolume(box("world_s", 100, 100, 100, reg), "G4_Galactic", "World", reg)

    crystal = pg.geant4.LogicalVolume(
        box("crystal_s", *CRYSTAL, reg), "G4_CALCIUM_TUNGSTATE", "CrystalLV", reg
    )
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], crystal, "crystal", world, reg)

    outer = box("frame_outer", *FRAME, reg)
    window = box("frame_window", WINDOW, WINDOW, FRAME[2] + 2, reg)
    frame_s = pg.geant4.solid.Subtraction("frame_s", outer, window, [[0, 0, 0], [0, 0, 0]], reg)
    frame = pg.geant4.LogicalVolume(frame_s, "G4_Cu", "FrameLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], frame, "frame", world, reg)

    clamp = pg.geant4.LogicalVolume(box("clamp_s", *CLAMP, reg), "G4_Cu", "clamp", reg)
    reach = CRYSTAL[0] / 2 + WINDOW / 2 - CRYSTAL[0] / 2 + 1 - CLAMP[0] / 2  # 1 mm on the frame
    copy = 0
    sides = [(0.0, reach, 0.0), (0.5 * math.pi, 0.0, reach), (math.pi, -reach, 0.0)]
    sides.append((1.5 * math.pi, 0.0, -reach))  # +x, +y, -x, -y: turned about z
    for z in (CRYSTAL[2] / 2 + CLAMP[2] / 2, -CRYSTAL[2] / 2 - CLAMP[2] / 2):
        for angle, x, y in sides:
            name = f"clamp_{copy}"
            pg.geant4.PhysicalVolume([0, 0, angle], [x, y, z], clamp, name, world, reg, copy)
            copy += 1

    shell = box("housing_outer", *HOUSING, reg)
    inside = box("housing_inside", *(h - 2 * WALL for h in HOUSING), reg)
    housing_s = pg.geant4.solid.Subtraction("housing_s", shell, inside, [[0, 0, 0], [0, 0, 0]], reg)
    housing = pg.geant4.LogicalVolume(housing_s, "G4_Cu", "HousingLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], housing, "housing", world, reg)

    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("module.gdml")
    print(f"wrote {os.path.relpath(module(out))}")
