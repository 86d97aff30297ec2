"""The chemical elements and the names built on them: the one home of score4's periodic table.

- element symbols by atomic number (``ELEMENTS``, :func:`atomic_number`);
- English element names as NIST material names spell them (``ELEMENT_NAMES``: ``"lead"`` ->
  ``"Pb"``), read by the material checks of :mod:`score4.inputs.materials`;
- nuclide and ion names: :func:`split_nuclide` reads what users write (``"Po-210"``,
  ``"210Po"``, ``"Pa234m"``), :func:`split_ion_name` the names Geant4 gives ions (``"Pb206"``),
  :func:`ground_state_name` drops Geant4's excitation suffix (``"Pb210[0.000]"``) and
  :func:`nuclide_za` checks element and mass number. Nuclide names in sources, decay data,
  ion species and vertex files all go through these.
"""

from __future__ import annotations

import re

from .errors import ConfigError

# Element symbols by atomic number, one line per period of the periodic table.
_TABLE = """
    H He
    Li Be B C N O F Ne
    Na Mg Al Si P S Cl Ar
    K Ca Sc Ti V Cr Mn Fe Co Ni Cu Zn Ga Ge As Se Br Kr
    Rb Sr Y Zr Nb Mo Tc Ru Rh Pd Ag Cd In Sn Sb Te I Xe
    Cs Ba La Ce Pr Nd Pm Sm Eu Gd Tb Dy Ho Er Tm Yb Lu Hf Ta W Re Os Ir Pt Au Hg Tl Pb Bi Po At Rn
    Fr Ra Ac Th Pa U Np Pu Am Cm Bk Cf Es Fm Md No Lr Rf Db Sg Bh Hs Mt Ds Rg Cn Nh Fl Mc Lv Ts Og
    """

#: Element symbols by atomic number: ``ELEMENTS[Z - 1]``.
ELEMENTS: tuple[str, ...] = tuple(_TABLE.split())

_Z_LOWER = {symbol.lower(): z for z, symbol in enumerate(ELEMENTS, start=1)}


def atomic_number(symbol: str) -> int | None:
    """Z of an element symbol in any case (``"pb"``, ``"Pb"``), None for an unknown symbol."""
    return _Z_LOWER.get(symbol.lower())


def nuclide_za(symbol: str, mass: str, name: str, what: str) -> tuple[int, int]:
    """Z and A of nuclide ``name`` read as element ``symbol`` and mass number ``mass``.

    Raises ConfigError naming ``what`` for an unknown element or a mass number outside
    [Z, 300]; the one check behind every nuclide name score4 reads.
    """
    z = atomic_number(symbol)
    if z is None:
        raise ConfigError(f"{what}: {name!r} has unknown element symbol {symbol!r}")
    a = int(mass)
    if not z <= a <= 300:
        raise ConfigError(
            f"{what}: {name!r} has mass number {a}; it must be between Z = {z} and 300"
        )
    return z, a


# Element names (English, as NIST material names spell them) and their symbols, Z = 1 to 98,
# with the other common spellings (aluminium, sulphur, caesium, wolfram).
_NAMES_TEXT = (
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
_NAME_WORDS = _NAMES_TEXT.split()
#: English element name (lower case) -> symbol: ``ELEMENT_NAMES["lead"] == "Pb"``.
ELEMENT_NAMES: dict[str, str] = dict(zip(_NAME_WORDS[::2], _NAME_WORDS[1::2], strict=True))

# A nuclide as users write it: symbol and mass number either way round, with an optional '-'.
_SYMBOL, _MASS = r"([A-Za-z]{1,2})", r"(\d{1,3})"
_NUCLIDE = re.compile(rf"^\s*(?:{_SYMBOL}-?{_MASS}|{_MASS}-?{_SYMBOL})\s*$")
# ... also with 'm' after the mass number for a metastable state (``Pa234m``, ``234mPa``).
_NUCLIDE_STATE = re.compile(
    rf"^\s*(?:{_SYMBOL}-?{_MASS}(m)?|{_MASS}(m)?-?{_SYMBOL})\s*$", re.IGNORECASE
)
# An ion as Geant4 names it: capitalised symbol, then the mass number (``Pb206``).
_G4_ION = re.compile(r"^([A-Z][a-z]?)-?(\d{1,3})$")
# Geant4's excitation suffix of an ion name: ``Pb210[0.000]``, ``Pa234[73.920]``.
_EXCITATION = re.compile(r"\[.*\]$")


def split_nuclide(name: str, metastable: bool = False) -> tuple[str, str, bool] | None:
    """Element symbol, mass number and metastable flag of a nuclide name as users write it.

    ``"Po-210"``, ``"po210"``, ``" 210Po "`` -> ``("Po"/"po", "210", False)`` (symbols as
    written; :func:`nuclide_za` checks them); with ``metastable``, ``"Pa234m"`` and ``"234mPa"``
    give True. None if ``name`` is not written that way.
    """
    if metastable:
        m = _NUCLIDE_STATE.match(name)
        if m is None:
            return None
        if m.group(1):
            return m.group(1), m.group(2), bool(m.group(3))
        return m.group(6), m.group(4), bool(m.group(5))
    m = _NUCLIDE.match(name)
    if m is None:
        return None
    if m.group(1):
        return m.group(1), m.group(2), False
    return m.group(4), m.group(3), False


def split_ion_name(name: str) -> tuple[str, int] | None:
    """Symbol and mass number of an ion named the Geant4 way (``"Pb206"``, also ``"Pb-206"``);
    None for any other name (``"alpha"``, ``"pb206"``). The symbol is not checked."""
    m = _G4_ION.match(name)
    return None if m is None else (m.group(1), int(m.group(2)))


def ground_state_name(name: str) -> str:
    """A Geant4 particle name without its excitation suffix: ``"Pb210[0.000]"`` -> ``"Pb210"``."""
    return _EXCITATION.sub("", name)
