"""GDML export and import through Geant4's own G4GDMLParser."""

from __future__ import annotations

import os
import re
from pathlib import Path

from score4.inputs.materials import find_material

from ..errors import Score4Error


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
    from .. import files

    complete = files.ends_with(b"</gdml>", "GDML file")
    with files.atomic_output(path, complete, ".partial.gdml") as tmp:
        tmp.unlink()  # G4GDMLParser refuses to overwrite
        parser = g4.G4GDMLParser()
        parser.SetAddPointerToName(False)  # stable names, readable by other tools
        parser.Write(str(tmp), pv_world, False)
        if not tmp.is_file():
            raise Score4Error(f"gdml: Geant4 did not write {path} (see Geant4's output)")
        tmp.write_text(drop_nist_state(tmp.read_text()))
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
    Files the GDML pulls in with ``<file name=...>`` are found relative to its folder (Geant4
    takes them relative to the working directory, which is changed for the read).
    """
    path = Path(path).resolve()
    if not path.is_file():
        raise Score4Error(f"gdml: file {str(path)!r} does not exist")
    parser = g4.G4GDMLParser()
    here = os.getcwd()
    os.chdir(path.parent)
    try:
        parser.Read(str(path), False)
    finally:
        os.chdir(here)
    return parser, parser.GetWorldVolume()


# -- the volume model of a GDML world ---------------------------------------------------------

#: Solid parameters read from live solids (Geant4's conventions: mm, rad, half-lengths).
_SOLID_PARAMETERS = {
    "G4Box": (("x", "GetXHalfLength"), ("y", "GetYHalfLength"), ("z", "GetZHalfLength")),
    "G4Tubs": (
        ("rmin", "GetInnerRadius"),
        ("rmax", "GetOuterRadius"),
        ("dz", "GetZHalfLength"),
        ("sphi", "GetStartPhiAngle"),
        ("dphi", "GetDeltaPhiAngle"),
    ),
}


def solid_record(g4, solid) -> dict:
    """Type, name, parameters (G4Box, G4Tubs), bounding limits, volume and area of a solid.

    Volume and area are Geant4's own (``GetCubicVolume``, ``GetSurfaceArea``): exact for the
    CSG solids, Monte Carlo estimates for booleans and a few others (Geant4 caches them).
    ``shape`` is the :mod:`score4.shapes` description (``to_dict``), for sources on any volume.
    """
    kind = str(solid.GetEntityType())
    params = {
        key: float(getattr(solid, getter)()) for key, getter in _SOLID_PARAMETERS.get(kind, ())
    }
    lo, hi = g4.G4ThreeVector(), g4.G4ThreeVector()
    solid.BoundingLimits(lo, hi)
    return {
        "type": kind,
        "name": str(solid.GetName()),
        "params": params,
        "shape": _shape_dict(solid),
        "lo": [lo.x, lo.y, lo.z],
        "hi": [hi.x, hi.y, hi.z],
        "volume_mm3": float(solid.GetCubicVolume()),
        "area_mm2": float(solid.GetSurfaceArea()),
    }


def _shape_dict(solid) -> dict | None:
    """The solid as :mod:`score4.shapes` plain data (None: a type it does not describe)."""
    from ..errors import ConfigError
    from .solid_shapes import shape_from_g4_solid

    try:
        return shape_from_g4_solid(solid, live_fallback=False).to_dict()
    except ConfigError:
        return None


def material_record(g4, material) -> dict:
    """Density, state and elements of a G4Material.

    Each element: name, symbol, Z, molar mass (the isotopes' abundance-weighted mean, so an
    enriched element made of isotopes keeps its own), mass fraction, atoms per mm3 and its
    isotopes (name, Z, N, molar mass; the binding does not give their abundances).
    """
    elements = material.GetElementVector()
    fractions = list(material.GetFractionVector())
    per_volume = list(material.GetVecNbOfAtomsPerVolume())
    amu = float(g4.g / g4.mole)
    out = []
    for i in range(len(elements)):
        el = elements[i]
        isotopes = el.GetIsotopeVector()
        out.append(
            {
                "name": str(el.GetName()),
                "symbol": str(el.GetSymbol()),
                "Z": round(el.GetZ()),
                "A_g_mole": float(el.GetA()) / amu,
                "mass_fraction": float(fractions[i]),
                "atoms_per_mm3": float(per_volume[i]),
                "isotopes": [
                    {
                        "name": str(isotopes[j].GetName()),
                        "Z": int(isotopes[j].GetZ()),
                        "N": int(isotopes[j].GetN()),
                        "A_g_mole": float(isotopes[j].GetA()) / amu,
                    }
                    for j in range(len(isotopes))
                ],
            }
        )
    return {
        "density_g_cm3": float(material.GetDensity()) / float(g4.g / g4.cm3),
        "state": str(material.GetState()).rsplit(".", 1)[-1],
        "elements": out,
    }


def extract_model(g4, world_pv, source: str, files: list[str], live: list | None = None) -> dict:
    """The plain-data model (:class:`score4.world.gdml_model.GeometryModel`) of a live world.

    ``live``, if given, receives the live logical volumes in the order of the model's
    ``logicals`` (their Python objects, so identity tests against a user's objects work).
    """
    from score4.world.gdml_model import MODEL_FORMAT

    index: dict[int, int] = {}  # id of a logical volume's Python object -> model index
    alive: list = []  # keeps those objects (and so their ids) alive
    logicals: list[dict] = []
    materials: dict[str, dict] = {}
    todo: list = []

    def number(lv) -> int:
        key = id(lv)
        if key not in index:
            index[key] = len(alive)
            alive.append(lv)
            logicals.append({})
            todo.append(lv)
        return index[key]

    number(world_pv.GetLogicalVolume())
    while todo:
        lv = todo.pop()
        k = index[id(lv)]
        material = lv.GetMaterial()
        mname = str(material.GetName())
        if mname not in materials:
            materials[mname] = material_record(g4, material)
        daughters = []
        for i in range(lv.GetNoDaughters()):
            pv = lv.GetDaughter(i)
            r = pv.GetObjectRotationValue()
            t = pv.GetTranslation()
            kind = (
                "parameterised"
                if pv.IsParameterised()
                else "replica"
                if pv.IsReplicated()
                else "placement"
            )
            daughters.append(
                {
                    "name": str(pv.GetName()),
                    "copy": int(pv.GetCopyNo()),
                    "logical": number(pv.GetLogicalVolume()),
                    "rotation": [r.xx, r.xy, r.xz, r.yx, r.yy, r.yz, r.zx, r.zy, r.zz],
                    "translation": [t.x, t.y, t.z],
                    "kind": kind,
                    "multiplicity": int(pv.GetMultiplicity()),
                }
            )
        logicals[k] = {
            "name": str(lv.GetName()),
            "solid": solid_record(g4, lv.GetSolid()),
            "material": mname,
            "daughters": daughters,
        }
    if live is not None:
        live.extend(alive)
    return {
        "format": MODEL_FORMAT,
        "source": source,
        "world": 0,
        "world_name": str(world_pv.GetName()),
        "files": files,
        "materials": materials,
        "logicals": logicals,
    }
