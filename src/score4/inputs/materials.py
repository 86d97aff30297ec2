"""Materials: Geant4's NIST database plus the run's own ``materials:`` entries, with helpful
errors."""

from __future__ import annotations

import difflib
import functools
import re
from collections.abc import Mapping, Sequence
from importlib import resources

from ..common.records import kind_of
from ..elements import ELEMENT_NAMES
from ..errors import ConfigError, brief


def check_material_name(name: str) -> None:
    """Raise ValueError unless ``name`` may name a ``materials:`` entry."""
    if name.startswith("G4_"):
        raise ValueError(
            f"{name!r}: names starting with G4_ belong to Geant4's NIST database; "
            f"use a NIST name directly or give this material another name"
        )
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_\-+.]*", name):
        raise ValueError(
            f"{name!r}: a material name starts with a letter or _ and holds letters, "
            f"digits and _ - + ."
        )


def nist_material_names(g4) -> list[str]:
    """Every material name of Geant4's NIST database (``G4_Si``, ``G4_CALCIUM_TUNGSTATE``, ...)."""
    return list(g4.G4NistManager.Instance().GetNistMaterialNames())


@functools.cache
def shipped_nist_names() -> tuple[str, ...]:
    """The NIST material names as shipped with score4 (no Geant4 import; the same list)."""
    text = resources.files("score4").joinpath("data/nist_materials.txt").read_text()
    return tuple(line.strip() for line in text.splitlines() if line.strip() and line[0] != "#")


def check_material(
    name: str, parameter: str, materials: Mapping | None = None, known: Sequence[str] = ()
) -> None:
    """Refuse a material that is neither a ``materials:`` entry nor a NIST name, with the
    closest names (the check :func:`find_material` makes, without Geant4)."""
    materials = materials or {}
    known = list(known) or list(shipped_nist_names())
    if name in materials or name in known:
        return
    close = suggest_materials(name, list(materials) + known)
    which = "names" if materials else "NIST names"
    hint = (
        f"; closest {which}: {', '.join(close)}"
        if close
        else "; NIST names look like G4_Si, G4_Cu, G4_Galactic"
    )
    custom = f" (materials: defines {', '.join(materials)})" if materials else ""
    raise ConfigError(f"{parameter}: unknown material {brief(name)}{hint}{custom}")


def _as_spec(spec):
    if kind_of(spec) == "MaterialSpec":  # the model, or a worker's record of it
        return spec
    if isinstance(spec, Mapping):
        from pydantic import ValidationError

        from score4.common.schema import describe_validation_error

        from .material_spec import MaterialSpec

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
    """The G4Material ``name``: a ``materials:`` entry or a NIST name; else raise with close
    names."""
    materials = materials or {}
    if name in materials:
        return build_material(g4, name, materials[name])
    nist = g4.G4NistManager.Instance()
    check_material(name, parameter, materials, nist_material_names(g4))
    return nist.FindOrBuildMaterial(name)


# Anions of NIST compound names, as formulas: G4_CALCIUM_TUNGSTATE reads as CaWO4.
_ANIONS = {
    "IODIDE": "I",
    "FLUORIDE": "F",
    "CHLORIDE": "Cl",
    "BROMIDE": "Br",
    "OXIDE": "O",
    "DIOXIDE": "O2",
    "TRIOXIDE": "O3",
    "TUNGSTATE": "WO4",
    "CARBONATE": "CO3",
    "SULFATE": "SO4",
    "NITRATE": "NO3",
    "HEXAFLUORIDE": "F6",
    "TETRABORATE": "B4O7",
    "SULFIDE": "S",
    "NITRIDE": "N",
    "CARBIDE": "C",
}
# Common short names of materials whose NIST name says something else.
_ALIASES = {
    "ptfe": "teflon",
    "h2o": "water",
    "vacuum": "galactic",
    "bi4ge3o12": "bgo",
    "pe": "polyethylene",
    "pmma": "plexiglass",
    "steel": "stainless-steel",
}

# Characters people (and OCR) confuse: compared as the same letter.
_CONFUSABLE = str.maketrans({"l": "i", "1": "i", "|": "i", "0": "o"})


def _body(name: str) -> str:
    name = name.strip()
    return name[3:] if name.upper().startswith("G4_") else name


def _forms(name: str, query: bool) -> set[str]:
    """Ways to write a material, reduced for comparison (lower case, look-alikes equal).

    A NIST name also reads as its formula (``CALCIUM_TUNGSTATE``: ``cawo4``); a query also
    reads as the symbol of the element it names (``silicon``, ``SILICON``, ``silicn``: ``si``)
    and as the NIST name of a common short name (``PTFE``: ``teflon``).
    """
    body = _body(name)
    forms = {body.lower()}
    if query:
        element = difflib.get_close_matches(body.lower(), list(ELEMENT_NAMES), n=1, cutoff=0.8)
        if element:
            forms.add(ELEMENT_NAMES[element[0]].lower())
        if body.lower() in _ALIASES:
            forms.add(_ALIASES[body.lower()])
    else:
        parts = body.upper().split("_")
        if len(parts) == 2 and parts[1] in _ANIONS:
            symbol = ELEMENT_NAMES.get(parts[0].lower())
            if symbol:
                forms.add((symbol + _ANIONS[parts[1]]).lower())
    return {f.translate(_CONFUSABLE) for f in forms}


def suggest_materials(name: str, known: list[str], n: int = 5) -> list[str]:
    """Up to ``n`` NIST names closest to ``name``, best first.

    Names are compared without the ``G4_`` prefix and case, with element names read as their
    symbols and compound names as their formulas (``G4_SILICON`` and ``silicon`` are ``Si``,
    ``CaWO4`` is ``G4_CALCIUM_TUNGSTATE``) and look-alike characters (l, 1 / i, 0 / o) equal,
    so ``G4_SILICON`` and ``G4_Sl`` both give ``G4_Si`` first.
    """
    targets = _forms(name, query=True)
    scored = []
    for candidate in known:
        best = 0.0
        for other in _forms(candidate, query=False):
            for target in targets:
                ratio = difflib.SequenceMatcher(None, target, other).ratio()
                if other == target:
                    ratio = 2.0
                elif len(other) == len(target):
                    ratio += 0.05  # the same length: a replaced letter rather than a missing one
                best = max(best, ratio)
        scored.append((-best, candidate))
    scored.sort()
    return [c for r, c in scored[:n] if -r >= 0.5]
