"""GDML worlds for the geometry tests, written at test time by the field's writers.

* :func:`pyg4ometry_world`: pyg4ometry (with a BEGe detector of legend-pygeom-hpges made of
  enriched germanium, an element defined from isotopes), a rotated mother holding three copies of
  one crystal, a copper disk, a boolean solid elsewhere, its materials in an XML entity file and a
  module pulled in with ``<file name=...>``;
* :func:`geant4_world`: Geant4's own writer (``G4GDMLParser.Write``, names with pointer
  suffixes) in a spawned process: nested rotated mothers, two copies of one crystal, a union;
* :func:`reflected_world`: pyg4ometry with a reflected placement (``scale``).

Only the pyg4ometry and Geant4 calls here write geometry; the text edits move blocks the writer
made (materials into an entity, a ``<file>`` reference into a placement).

:func:`cached` keeps the written files in score4's cache folder (``test-gdml-worlds``), keyed by
this file's content and the writers' versions: writing them takes ~15 s (a spawned Geant4, the
HPGe detector), and files that stay the same also keep their volume models cached.
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
from collections.abc import Callable
from importlib.metadata import version
from pathlib import Path

from helpers.spawn import run_in_spawned_process

#: Crystal (full edges, mm), its copies' positions in the cavity and rotations about z (rad).
CRYSTAL = (20.0, 30.0, 40.0)
CRYSTAL_POSITIONS = [(-60.0, 0.0, 0.0), (0.0, 0.0, 0.0), (60.0, 0.0, 0.0)]
CRYSTAL_ROT_Z = [0.0, 0.5, 1.0]
CAVITY_ROTATION = (0.1, 0.2, 0.3)  # GDML x, y, z angles (rad)
CAVITY_POSITION = (10.0, 0.0, 0.0)
DISK = {"rmin": 0.0, "rmax": 15.0, "dz": 5.0}  # G4Tubs, mm (full length 10 mm)
DISK_POSITION = (0.0, 60.0, 0.0)
HOLDER_POSITION = (0.0, -60.0, 0.0)  # module (from <file>) in the cavity
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
BEGE_POSITION = (0.0, 0.0, 250.0)


def _module(folder: Path) -> Path:
    """A copper holder box with a small silicon chip inside (its own GDML file)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    ws = pg.geant4.solid.Box("module_world_s", 40, 20, 20, reg)
    wl = pg.geant4.LogicalVolume(ws, "G4_Galactic", "ModuleWorld", reg)
    hs = pg.geant4.solid.Box("holder_s", 30, 10, 10, reg)
    hl = pg.geant4.LogicalVolume(hs, "G4_Cu", "HolderLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], hl, "holder", wl, reg)
    cs = pg.geant4.solid.Box("chip_s", 4, 4, 2, reg)
    cl = pg.geant4.LogicalVolume(cs, "G4_Si", "ChipLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 2], cl, "chip", hl, reg)
    reg.setWorld(wl.name)
    path = folder / "module.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def pyg4ometry_world(folder: Path) -> Path:
    """Write ``folder/setup.gdml`` (+ ``materials.xml``, ``module.gdml``); return its path."""
    import pyg4ometry as pg
    from pygeomhpges import make_hpge

    folder.mkdir(parents=True, exist_ok=True)
    _module(folder)
    reg = pg.geant4.Registry()
    ws = pg.geant4.solid.Box("world_s", 800, 800, 800, reg)
    wl = pg.geant4.LogicalVolume(ws, "G4_Galactic", "World", reg)
    cav_s = pg.geant4.solid.Box("cavity_s", 200, 200, 200, reg)
    cav = pg.geant4.LogicalVolume(cav_s, "G4_Galactic", "CavityLV", reg)
    pg.geant4.PhysicalVolume(list(CAVITY_ROTATION), list(CAVITY_POSITION), cav, "cavity", wl, reg)
    cs = pg.geant4.solid.Box("crystal_s", *CRYSTAL, reg)
    cl = pg.geant4.LogicalVolume(cs, "G4_CALCIUM_TUNGSTATE", "CrystalLV", reg)
    for k, (pos, rz) in enumerate(zip(CRYSTAL_POSITIONS, CRYSTAL_ROT_Z, strict=True)):
        pg.geant4.PhysicalVolume([0, 0, rz], list(pos), cl, f"crystal_{k}", cav, reg, copyNumber=k)
    ds = pg.geant4.solid.Tubs(
        "disk_s", DISK["rmin"], DISK["rmax"], 2 * DISK["dz"], 0, 2 * math.pi, reg
    )
    dl = pg.geant4.LogicalVolume(ds, "G4_Cu", "DiskLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(DISK_POSITION), dl, "disk", cav, reg)
    b1 = pg.geant4.solid.Box("bool_a", 20, 20, 20, reg)
    b2 = pg.geant4.solid.Tubs("bool_b", 0, 5, 40, 0, 2 * math.pi, reg)
    sub = pg.geant4.solid.Subtraction("bool_s", b1, b2, [[0, 0, 0], [0, 0, 0]], reg)
    sl = pg.geant4.LogicalVolume(sub, "G4_Cu", "BoolLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, -250], sl, "boolpart", wl, reg)
    bege = make_hpge(BEGE, registry=reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(BEGE_POSITION), bege, "bege", wl, reg)
    reg.setWorld(wl.name)
    path = folder / "setup.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    _split_materials(path)
    _include_module(path, "CavityLV", "module.gdml", HOLDER_POSITION)
    return path


def _split_materials(path: Path) -> None:
    """Move the written <materials> block into materials.xml, pulled in by an XML entity."""
    text = path.read_text()
    start, end = text.index("<materials>"), text.index("</materials>") + len("</materials>")
    (path.parent / "materials.xml").write_text(text[start:end] + "\n")
    head, _, rest = text.partition("<gdml")
    doctype = '<!DOCTYPE gdml [\n<!ENTITY materials SYSTEM "materials.xml">\n]>\n'
    text = head + doctype + "<gdml" + rest
    start, end = text.index("<materials>"), text.index("</materials>") + len("</materials>")
    path.write_text(text[:start] + "&materials;" + text[end:])


def _include_module(path: Path, mother: str, module: str, position: tuple) -> None:
    """Add ``<physvol><file name=module/></physvol>`` to logical volume ``mother``."""
    text = path.read_text()
    at = text.index(f'<volume name="{mother}">')
    close = text.index("</volume>", at)
    x, y, z = position
    physvol = (
        f'\t\t\t<physvol name="module">\n\t\t\t\t<file name="{module}"/>\n'
        f'\t\t\t\t<position name="module_pos" x="{x}" y="{y}" z="{z}" unit="mm"/>\n'
        "\t\t\t</physvol>\n\t\t"
    )
    path.write_text(text[:close] + physvol + text[close:])


def reflected_world(folder: Path) -> Path:
    """A world with one crystal placed with a reflection (scale z = -1)."""
    import pyg4ometry as pg

    folder.mkdir(parents=True, exist_ok=True)
    reg = pg.geant4.Registry()
    ws = pg.geant4.solid.Box("world_s", 200, 200, 200, reg)
    wl = pg.geant4.LogicalVolume(ws, "G4_Galactic", "World", reg)
    cs = pg.geant4.solid.Box("crystal_s", 10, 10, 10, reg)
    cl = pg.geant4.LogicalVolume(cs, "G4_Si", "CrystalLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [30, 0, 0], cl, "straight", wl, reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [-30, 0, 0], cl, "mirrored", wl, reg, scale=[1, 1, -1])
    reg.setWorld(wl.name)
    path = folder / "reflected.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


# -- Geant4's writer, in a spawned process ------------------------------------------------------

#: Geant4-written world: outer mother rotated about x, inner mother about z, crystal twice.
G4_OUTER = {"half": (100.0, 100.0, 100.0), "rot_x": 0.3, "pos": (5.0, -5.0, 0.0)}
G4_INNER = {"half": (50.0, 50.0, 30.0), "rot_z": 0.7, "pos": (0.0, 10.0, 20.0)}
G4_CRYSTAL = {"half": (5.0, 8.0, 10.0), "pos": [(-20.0, 0.0, 0.0), (20.0, 0.0, 0.0)]}


def _write_geant4_world(path: str) -> None:
    from score4.sim.runtime import import_geant4, resolve_physics

    g4 = import_geant4(resolve_physics("lite"))
    nist = g4.G4NistManager.Instance()
    vac, cu, ge = (nist.FindOrBuildMaterial(m) for m in ("G4_Galactic", "G4_Cu", "G4_Ge"))
    vec = g4.G4ThreeVector
    keep = []

    def lv(solid, material, name):
        v = g4.G4LogicalVolume(solid, material, name)
        keep.extend([solid, v])
        return v

    def place(rot, pos, volume, name, mother, copy=0):
        r = g4.G4RotationMatrix()
        r.rotateX(rot[0])
        r.rotateZ(rot[1])
        pv = g4.G4PVPlacement(g4.G4Transform3D(r, vec(*pos)), volume, name, mother, False, copy)
        keep.extend([r, pv])
        return pv

    world = lv(g4.G4Box("World", 300, 300, 300), vac, "World")
    world_pv = g4.G4PVPlacement(None, vec(), world, "World", None, False, 0)
    outer = lv(g4.G4Box("Outer", *G4_OUTER["half"]), vac, "Outer")
    place((G4_OUTER["rot_x"], 0.0), G4_OUTER["pos"], outer, "outer", world)
    inner = lv(g4.G4Box("Inner", *G4_INNER["half"]), vac, "Inner")
    place((0.0, G4_INNER["rot_z"]), G4_INNER["pos"], inner, "inner", outer)
    crystal = lv(g4.G4Box("Crystal", *G4_CRYSTAL["half"]), ge, "Crystal")
    for k, pos in enumerate(G4_CRYSTAL["pos"]):
        place((0.0, 0.0), pos, crystal, "crystal", inner, k)
    a, b = g4.G4Box("ua", 10, 10, 10), g4.G4Tubs("ub", 0, 5, 20, 0, 2 * math.pi)
    union = g4.G4UnionSolid("union", a, b)
    keep += [a, b, union]
    place((0.0, 0.0), (0.0, 0.0, -200.0), lv(union, cu, "UnionLV"), "unionpart", world)
    parser = g4.G4GDMLParser()
    parser.Write(path, world_pv, True)  # Geant4's default: names with pointer suffixes


def geant4_world(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "geant4_written.gdml"
    path.unlink(missing_ok=True)
    run_in_spawned_process(_write_geant4_world, str(path))
    return path


def touching_world(folder: Path) -> Path:
    """Two 10 mm silicon cubes side by side along x, touching at x = 0 (pyg4ometry)."""
    import pyg4ometry as pg

    folder.mkdir(parents=True, exist_ok=True)
    reg = pg.geant4.Registry()
    ws = pg.geant4.solid.Box("world_s", 100, 100, 100, reg)
    wl = pg.geant4.LogicalVolume(ws, "G4_Galactic", "World", reg)
    a = pg.geant4.LogicalVolume(pg.geant4.solid.Box("a_s", 10, 10, 10, reg), "G4_Si", "ALV", reg)
    b = pg.geant4.LogicalVolume(pg.geant4.solid.Box("b_s", 10, 10, 10, reg), "G4_Cu", "BLV", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [-5, 0, 0], a, "left", wl, reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [5, 0, 0], b, "right", wl, reg)
    reg.setWorld(wl.name)
    path = folder / "touching.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def cached(name: str, writer: Callable[[Path], Path]) -> Path:
    """The file ``writer(folder)`` writes, made once per content of this module and versions of
    the writers, then taken from score4's cache folder (a crashed or concurrent writer leaves no
    half-written world: the folder is renamed into place when complete)."""
    from score4.files import cache_dir

    digest = hashlib.sha256(Path(__file__).read_bytes())
    for package in ("pyg4ometry", "legend-pygeom-hpges", "geant4_pybind"):
        digest.update(f"{package} {version(package)}".encode())
    folder = cache_dir("test-gdml-worlds", digest.hexdigest()[:16], name)
    done = folder / ".complete"
    if done.is_file():
        return folder / done.read_text().strip()
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = folder.parent / f".{name}.{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    path = writer(tmp)
    (tmp / ".complete").write_text(path.name)
    try:
        tmp.rename(folder)
    except OSError:  # another process finished first
        shutil.rmtree(tmp, ignore_errors=True)
    return folder / path.name
