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
    """Elements (symbol, atom fraction; fractions sum to 1) and density in g/cm3.

    ``masses`` holds molar masses (g/mol) of elements whose isotopic composition is not the
    natural one (enriched germanium of LEGEND's GDML: Z = 32, 75.6 g/mol); TRIM uses them
    instead of its natural atomic weights.
    """

    name: str
    atoms: tuple[tuple[str, float], ...]
    density: float
    masses: tuple[tuple[str, float], ...] = ()

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
        """The composition of a Geant4 ``G4Material`` (atoms per volume of each element).

        Elements are taken by their atomic number, not their name or symbol: GDML files define
        elements of their own (``EnrGe0.750``, made of Ge-74 and Ge-76). An element whose molar
        mass differs from TRIM's natural one by more than 0.5 % keeps its own in ``masses``;
        several elements of one Z are merged (atom-weighted mean mass).
        """
        import numpy as np

        elements = material.GetElementVector()
        per_volume = np.asarray(material.GetVecNbOfAtomsPerVolume(), dtype=float)
        parts = [
            (round(elements[i].GetZ()), float(per_volume[i]), float(elements[i].GetA()))
            for i in range(len(elements))
        ]
        density = round(float(material.GetDensity()) / _G4_G_PER_CM3, 9)
        return cls.from_parts(
            str(material.GetName()), [(z, n, a / _G4_G_PER_MOLE) for z, n, a in parts], density
        )

    @classmethod
    def from_parts(
        cls, name: str, parts: list[tuple[int, float, float]], density: float
    ) -> Composition:
        """From ``(Z, atoms, molar mass g/mol)`` per element (see :meth:`from_g4_material`)."""
        from .species import SYMBOLS

        atoms: dict[int, float] = {}
        mass: dict[int, float] = {}
        for z, n, a in parts:
            if not 1 <= z <= len(SYMBOLS):
                raise ConfigError(f"material {name!r}: element with Z = {z} is not known to TRIM")
            atoms[z] = atoms.get(z, 0.0) + n
            mass[z] = mass.get(z, 0.0) + n * a
        masses = []
        for z, n in atoms.items():
            a = mass[z] / n if n > 0 else 0.0
            if n > 0 and abs(a - natural_weight(z)) > 5e-3 * natural_weight(z):
                masses.append((SYMBOLS[z - 1], round(a, 6)))
        return cls(
            name, tuple((SYMBOLS[z - 1], n) for z, n in atoms.items()), density, tuple(masses)
        )

    def mass_of(self, symbol: str) -> float | None:
        """The molar mass (g/mol) this composition gives ``symbol``, None for the natural one."""
        return dict(self.masses).get(symbol)

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
# g/mole in Geant4's internal units (MeV ns^2/mm^2 per mole).
_G4_G_PER_MOLE = 6.241509074460763e21


def natural_weight(z: int) -> float:
    """The natural atomic weight (g/mol) of element ``z`` as SRIM/TRIM takes it (lunasrim)."""
    from lunasrim import data_files

    return float(data_files.atomdata(z).natural_weight)
