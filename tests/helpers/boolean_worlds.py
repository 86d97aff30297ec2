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


#: a copper box (20 mm) less a cone (r 4 mm at z = -20 to 8 mm at z = +20) through it along z
CONEBORE_POSITION = (0.0, 60.0, 0.0)
#: a copper box (20 mm) with a tube (r 3 mm, 10 mm long) standing on its +z face off its centre
POSTBOX_POSITION = (60.0, 0.0, 0.0)
POST_AT = (4.0, 2.0, 15.0)
#: a copper box (20 mm) with a rod (r 5 mm, 40 mm long) through it along z, a union
CROSS_POSITION = (-60.0, 0.0, 0.0)
#: a silicon orb (r 3 mm) less a box beyond x = 1.5 mm
ORBCUT_POSITION = (0.0, 0.0, 60.0)
ORB_CUT = 1.5
#: a hexagonal copper prism (G4Polyhedra, 6 sides 8 mm from the axis, 20 mm long) less a box
#: beyond x, y = 4 mm (its side face ``seg_1`` is six planes)
HEXCUT_POSITION = (60.0, 60.0, 0.0)
HEX_CUT = 4.0


def write_more_world(path: Path) -> Path:
    """A second world of booleans: ``conebore`` (a box less a cone), ``postbox`` (a box with
    a post on a part of its +z face, a union), ``cross`` (a box with a rod through it, a union),
    ``orbcut`` (an orb less a box), ``hexcut`` (a G4Polyhedra less a box) and the ``stack`` of
    :func:`write_world`."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 300, 300, 300, reg), "G4_Galactic", "W", reg)
    box = s.Box("cone_a", 20, 20, 20, reg)
    cone = s.Cons("cone_b", 0, 4, 0, 8, 40, 0, 2 * math.pi, reg)
    cut = s.Subtraction("conebore_s", box, cone, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "conebore_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(CONEBORE_POSITION), lv, "conebore", world, reg)
    base = s.Box("post_a", 20, 20, 20, reg)
    post = s.Tubs("post_b", 0, 3, 10, 0, 2 * math.pi, reg)
    union = s.Union("postbox_s", base, post, [[0, 0, 0], list(POST_AT)], reg)
    lv = pg.geant4.LogicalVolume(union, "G4_Cu", "postbox_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(POSTBOX_POSITION), lv, "postbox", world, reg)
    disk = s.Tubs("stack_a", 0, 10, 10, 0, 2 * math.pi, reg)
    top = s.Tubs("stack_b", 0, 7, 10, 0, 2 * math.pi, reg)
    stack = s.Union("stack_s", disk, top, [[0, 0, 0], [0, 0, 10]], reg)
    lv = pg.geant4.LogicalVolume(stack, "G4_Cu", "stack_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(STACK_POSITION), lv, "stack", world, reg)
    cross_box = s.Box("cross_a", 20, 20, 20, reg)
    rod = s.Tubs("cross_b", 0, 5, 40, 0, 2 * math.pi, reg)
    cross = s.Union("cross_s", cross_box, rod, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(cross, "G4_Cu", "cross_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(CROSS_POSITION), lv, "cross", world, reg)
    orb = s.Orb("orbcut_a", 3, reg)
    cutter = s.Box("orbcut_b", 10, 10, 10, reg)
    orbcut = s.Subtraction("orbcut_s", orb, cutter, [[0, 0, 0], [ORB_CUT + 5, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(orbcut, "G4_Si", "orbcut_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(ORBCUT_POSITION), lv, "orbcut", world, reg)
    hexa = s.Polyhedra("hex_a", 0, 2 * math.pi, 6, 2, [-10, 10], [0, 0], [8, 8], reg)
    corner = s.Box("hex_b", 20, 20, 40, reg)
    at = [HEX_CUT + 10, HEX_CUT + 10, 0]
    hexcut = s.Subtraction("hexcut_s", hexa, corner, [[0, 0, 0], at], reg)
    lv = pg.geant4.LogicalVolume(hexcut, "G4_Cu", "hexcut_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(HEXCUT_POSITION), lv, "hexcut", world, reg)
    reg.setWorld(world.name)
    w = pg.gdml.Writer()
    w.addDetector(reg)
    w.write(str(path))
    return path


def write_box_holes(path: Path, holes, half: float = 10.0) -> Path:
    """A GDML world (pyg4ometry) of copper boxes (half width ``half``, mm), each less a hole:
    ``holes(s, reg)`` gives, per volume name, ``(the hole's pyg4ometry solid, its position in
    the box, the box's y in the world)`` (``s``: ``pyg4ometry.geant4.solid``)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 200, 200, 100, reg), "G4_Galactic", "W", reg)
    for name, (hole, at, y) in holes(s, reg).items():
        box = s.Box(f"{name}_a", 2 * half, 2 * half, 2 * half, reg)
        cut = s.Subtraction(f"{name}_s", box, hole, [[0, 0, 0], list(at)], reg)
        lv = pg.geant4.LogicalVolume(cut, "G4_Cu", f"{name}_lv", reg)
        pg.geant4.PhysicalVolume([0, 0, 0], [0, y, 0], lv, name, world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def copper_world_text(solids: str, at: dict[str, tuple[float, float, float]]) -> str:
    """A GDML world written as text: ``solids`` (GDML solids, a ``world_s`` among them, and a
    ``<name>_s`` per volume) and one copper volume ``<name>`` placed at ``at[name]`` (mm)."""
    volumes = "".join(
        f'<volume name="{v}_lv"><materialref ref="G4_Cu"/><solidref ref="{v}_s"/></volume>'
        for v in at
    )
    placed = "".join(
        f'<physvol name="{v}"><volumeref ref="{v}_lv"/>'
        f'<position name="{v}_at" x="{x}" y="{y}" z="{z}" unit="mm"/></physvol>'
        for v, (x, y, z) in at.items()
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<gdml><define/><materials/>'
        f"<solids>{solids}</solids><structure>{volumes}"
        f'<volume name="W"><materialref ref="G4_Galactic"/><solidref ref="world_s"/>{placed}'
        '</volume></structure><setup name="Default" version="1.0"><world ref="W"/></setup></gdml>'
    )


def write_cone_cross(path: Path) -> Path:
    """``conecross``: a copper box (20 mm) with a cone (r 4 mm at z = -20 to 6 mm at z = +20)
    through it along z, a union (the cone's wall is kept beyond the box's faces only)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 300, 300, 300, reg), "G4_Galactic", "W", reg)
    box = s.Box("conecross_a", 20, 20, 20, reg)
    cone = s.Cons("conecross_b", 0, 4, 0, 6, 40, 0, 2 * math.pi, reg)
    union = s.Union("conecross_s", box, cone, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(union, "G4_Cu", "conecross_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [5.0, -3.0, 2.0], lv, "conecross", world, reg)
    reg.setWorld(world.name)
    w = pg.gdml.Writer()
    w.addDetector(reg)
    w.write(str(path))
    return path
