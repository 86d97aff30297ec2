"""Target compositions shared by Geant4 materials and TRIM (lunasrim) targets.

A :class:`Composition` is what TRIM needs to know about a material: its elements with their
atom fractions and its density. score4 makes one from a chemical formula (``materials:`` in a
run configuration) or from a Geant4 material (NIST or custom), so the TRIM reference and the
Geant4 run describe the same matter, with the same density.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import ConfigError

_TOKEN = re.compile(r"([A-Z][a-z]?)(\d*\.?\d*)")


@dataclass(frozen=True)
class Composition:
    """Elements (symbol, atom fraction; fractions sum to 1) and density in g/cm3."""

    name: str
    atoms: tuple[tuple[str, float], ...]
    density: float

    def __post_init__(self) -> None:
        if not self.atoms:
            raise ConfigError(f"material {self.name!r}: has no elements")
        if not self.density > 0:
            raise ConfigError(
                f"material {self.name!r}: density must be > 0 g/cm3, got {self.density!r}"
            )
        total = sum(f for _, f in self.atoms)
        if not total > 0 or any(f < 0 for _, f in self.atoms):
            raise ConfigError(f"material {self.name!r}: atom fractions must be >= 0 and not all 0")
        object.__setattr__(self, "atoms", tuple((s, f / total) for s, f in self.atoms if f > 0))

    @classmethod
    def from_formula(cls, name: str, formula: str, density: float) -> Composition:
        """``Composition.from_formula("CaWO4", "CaWO4", 6.06)``; stoichiometries may be decimals."""
        text = formula.replace(" ", "")
        tokens = _TOKEN.findall(text)
        if not text or "".join(s + n for s, n in tokens) != text:
            raise ConfigError(
                f"material {name!r}: formula {formula!r} is not a chemical formula such as "
                f"'CaWO4' or 'Li2MoO4' (element symbols, each followed by its count)"
            )
        counts: dict[str, float] = {}
        for symbol, number in tokens:
            try:
                count = float(number) if number else 1.0
            except ValueError:  # "." alone
                count = math.nan
            if not (count > 0 and math.isfinite(count)):
                raise ConfigError(
                    f"material {name!r}: formula {formula!r}: the count of {symbol} must be a "
                    f"number > 0, got {number!r} (leave an element out rather than count it 0)"
                )
            counts[symbol] = counts.get(symbol, 0.0) + count
        return cls(name, tuple(counts.items()), float(density))

    @classmethod
    def from_g4_material(cls, material) -> Composition:
        """The composition of a Geant4 ``G4Material`` (atoms per volume of each element)."""
        import numpy as np

        elements = material.GetElementVector()
        per_volume = np.asarray(material.GetVecNbOfAtomsPerVolume(), dtype=float)
        atoms = tuple(
            (str(elements[i].GetSymbol()), float(per_volume[i])) for i in range(len(elements))
        )
        density = round(float(material.GetDensity()) / _G4_G_PER_CM3, 9)
        return cls(str(material.GetName()), atoms, density)

    @property
    def formula(self) -> str:
        """A readable formula with atom fractions normalised to the smallest one (``CaWO4``)."""
        smallest = min(f for _, f in self.atoms)
        parts = []
        for symbol, fraction in self.atoms:
            n = fraction / smallest
            parts.append(symbol + ("" if abs(n - 1) < 1e-6 else f"{n:.4g}"))
        return "".join(parts)

    def lunasrim_target(self) -> dict[str, float]:
        """The target as lunasrim takes it: ``{symbol: atom fraction}`` (give ``density`` too)."""
        return dict(self.atoms)


# Geant4's internal density unit is g/cm3 = 6.241509074460763e+18 (MeV ns^2/mm^5 mass units).
_G4_G_PER_CM3 = 6.241509074460763e18
