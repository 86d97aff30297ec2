"""Ion species by name: ``Pb206``, ``Pb-206``, ``206Pb``, ``alpha``, ``He4``, ``proton``.

Pure Python: the element symbols and a mass formula, so names can be checked (with the
closest valid names in the error) before Geant4 or lunasrim is involved.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

from ..elements import ELEMENTS, split_nuclide
from ..errors import ConfigError

# Element symbols by atomic number (index + 1), hydrogen to lawrencium.
SYMBOLS = list(ELEMENTS[:103])
Z_OF = {symbol: z for z, symbol in enumerate(SYMBOLS, start=1)}

# Atomic masses (amu) of the light ions, where the mass formula below is poor (AME 2020).
_LIGHT_MASS = {(1, 1): 1.00782503, (1, 2): 2.01410178, (1, 3): 3.01604928, (2, 3): 3.01602932}
_LIGHT_MASS[(2, 4)] = 4.00260325
# Geant4 particle names that are ions.
_NAMED = {"alpha": (2, 4), "proton": (1, 1), "deuteron": (1, 2), "triton": (1, 3), "He3": (2, 3)}


@dataclass(frozen=True)
class IonSpecies:
    """An ion: element symbol, atomic number ``z``, mass number ``a`` and atomic mass in amu."""

    symbol: str
    z: int
    a: int
    mass_amu: float

    @property
    def name(self) -> str:
        """The name Geant4 knows: ``alpha`` for He-4, ``proton`` for H-1, else ``Pb206``."""
        for name, za in _NAMED.items():
            if za == (self.z, self.a) and name != "He3":
                return name
        return f"{self.symbol}{self.a}"

    @property
    def label(self) -> str:
        """A readable label: ``Pb-206``, ``alpha``."""
        return self.name if self.name in _NAMED else f"{self.symbol}-{self.a}"


def atomic_mass_amu(z: int, a: int) -> float:
    """Atomic mass (amu) of the nuclide (z, a): AME values for A <= 4, else the Weizsaecker
    mass formula (within ~0.015 amu of the measured masses of heavy nuclides, 1e-4 relative,
    far below what changes a range)."""
    if (z, a) in _LIGHT_MASS:
        return _LIGHT_MASS[(z, a)]
    n = a - z
    pairing = 0.0 if a % 2 else (11.18 if z % 2 == 0 else -11.18) / a**0.5
    binding = (
        15.75 * a
        - 17.8 * a ** (2 / 3)
        - 0.711 * z * (z - 1) / a ** (1 / 3)
        - 23.7 * (a - 2 * z) ** 2 / a
        + pairing
    )
    return z * 1.00782503 + n * 1.00866492 - binding / 931.494


def parse_ion(name: str, parameter: str = "ION") -> IonSpecies:
    """The ion called ``name``; raises :class:`ConfigError` with close valid names otherwise."""
    text = str(name).strip()
    za = _NAMED.get(text.lower()) if text.lower() != "he3" else None
    if za is None:
        parts = split_nuclide(text)
        if parts is not None:
            symbol, number, _ = parts
            symbol = symbol[0].upper() + symbol[1:].lower()
            if symbol in Z_OF:
                za = (Z_OF[symbol], int(number))
    if za is None:
        examples = [*_NAMED, "Pb206", "Po210", "Rn222", "He4"]
        close = difflib.get_close_matches(text, examples, n=3, cutoff=0.5)
        hint = f" (closest: {', '.join(close)})" if close else ""
        raise ConfigError(
            f"{parameter}: unknown ion {text!r}{hint}; give alpha, proton or an element symbol "
            f"with its mass number such as Pb206, Pb-206 or He4"
        )
    z, a = za
    if a < z:
        raise ConfigError(
            f"{parameter}: {text!r} has mass number {a} below its atomic number {z}; "
            f"a nuclide needs A >= Z (e.g. Pb206)"
        )
    return IonSpecies(SYMBOLS[z - 1], z, a, atomic_mass_amu(z, a))
