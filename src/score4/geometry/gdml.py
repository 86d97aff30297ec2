"""GDML export and import through Geant4's own G4GDMLParser."""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..errors import Score4Error
from .materials import find_material


def write_solid_gdml(
    g4, solid, path: str | Path, material: str = "G4_Si", margin: float = 1.0
) -> None:
    """Write ``solid`` (placed in a vacuum world box) as a standalone GDML file, atomically.

    The file holds materials, the solid, a logical volume and a world, so any GDML reader
    (ROOT, another Geant4 application, pyg4ometry) can load it directly. Geant4 writes ``<T>``
    and ``<P>`` on every material; pyg4ometry 1.4.6 refuses them on NIST (``G4_``) materials
    ("Cannot set temperature for predefined or arbitrary materials"), so they are removed from
    those materials (see :func:`drop_nist_state`).
    """
    path = Path(path)
    lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
    solid.BoundingLimits(lo, hi)
    half = [max(abs(lo.x), abs(hi.x)), max(abs(lo.y), abs(hi.y)), max(abs(lo.z), abs(hi.z))]
    world_solid = g4.G4Box("World", *(h + margin for h in half))
    world_lv = g4.G4LogicalVolume(world_solid, find_material(g4, "G4_Galactic"), "World")
    lv = g4.G4LogicalVolume(solid, find_material(g4, material), solid.GetName() + "_lv")
    pv_world = g4.G4PVPlacement(None, g4.G4ThreeVector(), world_lv, "World", None, False, 0, False)
    pv = g4.G4PVPlacement(
        None, g4.G4ThreeVector(), lv, solid.GetName() + "_pv", world_lv, False, 0, False
    )
    tmp = path.with_name(path.name + ".partial.gdml")
    tmp.unlink(missing_ok=True)  # G4GDMLParser refuses to overwrite
    parser = g4.G4GDMLParser()
    parser.SetAddPointerToName(False)  # stable names, readable by other tools
    parser.Write(str(tmp), pv_world, False)
    if not tmp.is_file():
        raise Score4Error(f"gdml: Geant4 did not write {path} (see Geant4's output)")
    tmp.write_text(drop_nist_state(tmp.read_text()))
    os.replace(tmp, path)
    _keep = (world_solid, world_lv, lv, pv, pv_world)  # alive until written


_NIST_MATERIAL = re.compile(r'<material name="G4_[^"]*"[^>]*>.*?</material>', re.DOTALL)
_STATE = re.compile(r'[ \t]*<[TP] unit="[^"]*" value="[^"]*"/>\n?')


def drop_nist_state(text: str) -> str:
    """Remove the ``<T>``/``<P>`` elements of NIST (``G4_``) materials from GDML text.

    A NIST material is defined by its name: readers that know the NIST table (pyg4ometry)
    refuse to override its temperature and pressure, and Geant4 builds it from the density,
    state and composition the file still states. Only the gas G4_Galactic differs from the
    default temperature and pressure (2.73 K, 3e-18 Pa); neither enters the stopping of
    charged particles at fixed density.
    """
    return _NIST_MATERIAL.sub(lambda m: _STATE.sub("", m.group(0)), text)


def read_gdml(g4, path: str | Path):
    """Read a GDML file without schema validation (validation would fetch the schema online).

    Returns the parser (keep it alive) and the world physical volume.

    Read one GDML file per process: Geant4 keeps volumes in global stores, and a second file
    that reuses the first one's volume names was measured to return the first file's world.
    """
    path = Path(path)
    if not path.is_file():
        raise Score4Error(f"gdml: file {str(path)!r} does not exist")
    parser = g4.G4GDMLParser()
    parser.Read(str(path), False)
    return parser, parser.GetWorldVolume()
