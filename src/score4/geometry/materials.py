"""Material look-up in Geant4's NIST database with helpful errors."""

from __future__ import annotations

import difflib

from ..errors import ConfigError


def find_material(g4, name: str, parameter: str = "material"):
    """Return the G4Material ``name`` from the NIST database, or raise listing close names."""
    nist = g4.G4NistManager.Instance()
    known = list(nist.GetNistMaterialNames())
    if name not in known:
        close = suggest_materials(name, known)
        hint = (
            f"; closest NIST names: {', '.join(close)}"
            if close
            else "; NIST names look like G4_Si, G4_Cu, G4_Galactic"
        )
        raise ConfigError(f"{parameter}: unknown material {name!r}{hint}")
    return nist.FindOrBuildMaterial(name)


# Element names (English, as NIST material names spell them) and their symbols, Z = 1 to 98.
_ELEMENT_TEXT = (
    "hydrogen H helium He lithium Li beryllium Be boron B carbon C nitrogen N oxygen O "
    "fluorine F neon Ne sodium Na magnesium Mg aluminum Al aluminium Al silicon Si phosphorus P "
    "sulfur S sulphur S chlorine Cl argon Ar potassium K calcium Ca scandium Sc titanium Ti "
    "vanadium V chromium Cr manganese Mn iron Fe cobalt Co nickel Ni copper Cu zinc Zn "
    "gallium Ga germanium Ge arsenic As selenium Se bromine Br krypton Kr rubidium Rb "
    "strontium Sr yttrium Y zirconium Zr niobium Nb molybdenum Mo technetium Tc ruthenium Ru "
    "rhodium Rh palladium Pd silver Ag cadmium Cd indium In tin Sn antimony Sb tellurium Te "
    "iodine I xenon Xe cesium Cs caesium Cs barium Ba lanthanum La cerium Ce praseodymium Pr "
    "neodymium Nd promethium Pm samarium Sm europium Eu gadolinium Gd terbium Tb dysprosium Dy "
    "holmium Ho erbium Er thulium Tm ytterbium Yb lutetium Lu hafnium Hf tantalum Ta "
    "tungsten W wolfram W rhenium Re osmium Os iridium Ir platinum Pt gold Au mercury Hg "
    "thallium Tl lead Pb bismuth Bi polonium Po astatine At radon Rn francium Fr radium Ra "
    "actinium Ac thorium Th protactinium Pa uranium U neptunium Np plutonium Pu americium Am "
    "curium Cm berkelium Bk californium Cf"
)
_ELEMENTS = _ELEMENT_TEXT.split()
ELEMENT_SYMBOLS = dict(zip(_ELEMENTS[::2], _ELEMENTS[1::2]))

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
        element = difflib.get_close_matches(body.lower(), list(ELEMENT_SYMBOLS), n=1, cutoff=0.8)
        if element:
            forms.add(ELEMENT_SYMBOLS[element[0]].lower())
        if body.lower() in _ALIASES:
            forms.add(_ALIASES[body.lower()])
    else:
        parts = body.upper().split("_")
        if len(parts) == 2 and parts[1] in _ANIONS:
            symbol = ELEMENT_SYMBOLS.get(parts[0].lower())
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
