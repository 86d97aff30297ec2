"""The chemical elements by atomic number: the one periodic table of score4.

Nuclide and ion names (:mod:`score4.source.emitters`, :mod:`score4.decay.nuclear_data`), ion
species and target compositions (:mod:`score4.ions`) and material checks read it from here.
"""

from __future__ import annotations

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
