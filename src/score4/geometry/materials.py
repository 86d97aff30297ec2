"""Materials: Geant4's NIST database plus the run's own ``materials:`` entries, with helpful errors."""

from __future__ import annotations

import difflib
from collections.abc import Mapping

from ..errors import ConfigError


def nist_material_names(g4) -> list[str]:
    """Every material name of Geant4's NIST database (``G4_Si``, ``G4_CALCIUM_TUNGSTATE``, ...)."""
    return list(g4.G4NistManager.Instance().GetNistMaterialNames())


def closest_material_names(name: str, known: list[str], n: int = 5) -> list[str]:
    """Up to ``n`` names of ``known`` that look like ``name`` (also tried with a ``G4_`` prefix)."""
    close = difflib.get_close_matches(name, known, n=n, cutoff=0.5)
    if not close and not name.startswith("G4_"):
        close = difflib.get_close_matches("G4_" + name, known, n=n, cutoff=0.5)
    if not close:  # NIST compounds are upper case: G4_SODIUM_IODIDE
        upper = {k.upper(): k for k in known}
        close = [
            upper[c] for c in difflib.get_close_matches(name.upper(), list(upper), n=n, cutoff=0.5)
        ]
    return close


def _as_spec(spec):
    from ..config import MaterialSpec

    if isinstance(spec, MaterialSpec):
        return spec
    if isinstance(spec, Mapping):
        from pydantic import ValidationError

        from ..schema import describe_validation_error

        try:
            return MaterialSpec.model_validate(dict(spec))
        except ValidationError as err:
            raise ConfigError(describe_validation_error(err, "materials")) from None
    raise ConfigError(f"materials: expected a material description, got {spec!r}")


def build_material(g4, name: str, spec):
    """The G4Material ``name`` described by ``spec`` (a ``materials:`` entry), built once.

    Elements come from Geant4's NIST element table (natural isotopic composition); atom
    counts or fractions are turned into mass fractions with Geant4's own atomic masses. A
    second call with the same name returns the material built first.
    """
    existing = g4.G4Material.GetMaterial(name, False)
    if existing is not None:
        return existing
    spec = _as_spec(spec)
    nist = g4.G4NistManager.Instance()
    if spec.formula is not None:
        from ..ions.composition import Composition

        parts = dict(Composition.from_formula(name, spec.formula, spec.density).atoms)
        by_mass = False
    else:
        parts, by_mass = dict(spec.elements), spec.fractions == "mass"  # None: atoms
    elements = {}
    for symbol in parts:
        element = nist.FindOrBuildElement(symbol)
        if element is None:
            raise ConfigError(f"materials.{name}: Geant4 has no element {symbol!r}")
        elements[symbol] = element
    weights = dict(parts) if by_mass else {s: f * elements[s].GetA() for s, f in parts.items()}
    total = sum(weights.values())
    material = g4.G4Material(name, spec.density * g4.g / g4.cm3, len(elements))
    for symbol, element in elements.items():
        material.AddElement(element, float(weights[symbol] / total))
    return material


def find_material(g4, name: str, parameter: str = "material", materials: Mapping | None = None):
    """The G4Material ``name``: a ``materials:`` entry or a NIST name; else raise with close names."""
    materials = materials or {}
    if name in materials:
        return build_material(g4, name, materials[name])
    nist = g4.G4NistManager.Instance()
    known = nist_material_names(g4)
    if name not in known:
        close = closest_material_names(name, list(materials) + known)
        which = "names" if materials else "NIST names"
        hint = (
            f"; closest {which}: {', '.join(close)}"
            if close
            else "; NIST names look like G4_Si, G4_Cu, G4_Galactic"
        )
        custom = f" (materials: defines {', '.join(materials)})" if materials else ""
        raise ConfigError(f"{parameter}: unknown material {name!r}{hint}{custom}")
    return nist.FindOrBuildMaterial(name)
