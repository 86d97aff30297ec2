"""A ``materials:`` entry of the configuration: the validated model (pydantic; the parent's side).

Names, checks and the Geant4 materials built from an entry are in :mod:`score4.inputs.materials`,
which a worker imports without pydantic.
"""

from __future__ import annotations

import difflib
import math
from typing import ClassVar, Literal

from pydantic import model_validator

from score4.common.schema import GIVEN, PositiveDensity, StrictModel


class MaterialSpec(StrictModel):
    """A material that is not in Geant4's NIST database (an entry under ``materials:``).

    Give ``formula`` (``TeO2``, ``Li2MoO4``; decimal counts allowed) or ``elements``
    (symbol: fraction, by ``atoms`` (default) or by ``mass``), and the ``density`` with its unit
    ("6.02 g/cm3", "3070 kg/m3"; stored in g/cm3). Geant4 builds it from its NIST elements
    (natural isotopic composition); TRIM comparisons use the same atoms and density.
    """

    used_only_with: ClassVar[dict[str, object]] = {"fractions": ("elements", GIVEN)}

    formula: str | None = None
    elements: dict[str, float] | None = None
    fractions: Literal["atoms", "mass"] | None = None  # of elements; None means atoms
    density: PositiveDensity

    @model_validator(mode="after")
    def _one_description(self) -> MaterialSpec:
        from score4.ions.composition import Composition
        from score4.ions.species import Z_OF

        if (self.formula is None) == (self.elements is None):
            raise ValueError(
                "give either formula (e.g. TeO2) or elements (e.g. {Cu: 0.99, Sn: 0.01}), "
                + ("not both" if self.formula is not None else "none is given")
            )
        if self.formula is not None:
            if self.fractions is not None:
                raise ValueError("fractions belongs to elements; a formula counts atoms")
            composition = Composition.from_formula(self.formula, self.formula, self.density)
            symbols = [s for s, _ in composition.atoms]
        else:
            elements = self.elements or {}
            symbols = list(elements)
            if not symbols:
                raise ValueError("elements: give at least one element")
            bad = {s: f for s, f in elements.items() if not (f > 0 and math.isfinite(f))}
            if bad:
                raise ValueError(f"elements: fractions must be finite numbers > 0, got {bad}")
        for symbol in symbols:
            if symbol not in Z_OF:
                close = difflib.get_close_matches(symbol, list(Z_OF), n=3, cutoff=0.4)
                hint = f" (closest: {', '.join(close)})" if close else ""
                raise ValueError(f"unknown element symbol {symbol!r}{hint}")
        return self

    def composition(self, name: str):
        """The :class:`~score4.ions.composition.Composition` (atom fractions, g/cm3) of the entry.

        Mass fractions are turned into atom fractions with SRIM's natural atomic weights
        (lunasrim); Geant4 materials use Geant4's own
        (:func:`score4.inputs.materials.build_material`).
        """
        from score4.ions.composition import Composition

        if self.formula is not None:
            return Composition.from_formula(name, self.formula, self.density)
        atoms = dict(self.elements or {})
        if self.fractions == "mass":
            from lunasrim import data_files

            from score4.ions.species import Z_OF

            atoms = {s: w / data_files.atomdata(Z_OF[s]).natural_weight for s, w in atoms.items()}
        return Composition(name, tuple(atoms.items()), self.density)
