"""Quantities with units.

score4 works in Geant4's internal units: millimetre, MeV, nanosecond, radian. Configuration
files and the CLI take strings such as ``"5.3 MeV"`` or ``"20 nm"``; :func:`parse_quantity`
turns them into floats in internal units and says clearly what is wrong otherwise.
"""

from __future__ import annotations

import math
import re

from .errors import ConfigError

# Factors to internal units, per dimension.
LENGTH = {
    "pm": 1e-9,
    "nm": 1e-6,
    "um": 1e-3,
    "µm": 1e-3,
    "μm": 1e-3,
    "micron": 1e-3,
    "mm": 1.0,
    "cm": 10.0,
    "m": 1000.0,
    "km": 1e6,
}
ENERGY = {"eV": 1e-6, "keV": 1e-3, "MeV": 1.0, "GeV": 1e3, "TeV": 1e6}
TIME = {"ps": 1e-3, "ns": 1.0, "us": 1e3, "µs": 1e3, "ms": 1e6, "s": 1e9}
ANGLE = {"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180.0}
AREA = {"nm2": 1e-12, "um2": 1e-6, "mm2": 1.0, "cm2": 100.0, "m2": 1e6}
# Densities are kept in g/cm3 (not Geant4's internal mass unit), the unit of NIST tables,
# Geant4's printouts and SRIM; multiply by Geant4's ``g / cm3`` when building a G4Material.
DENSITY = {"g/cm3": 1.0, "mg/cm3": 1e-3, "kg/m3": 1e-3, "g/m3": 1e-6}

DIMENSIONS: dict[str, dict[str, float]] = {
    "length": LENGTH,
    "energy": ENERGY,
    "time": TIME,
    "angle": ANGLE,
    "area": AREA,
    "density": DENSITY,
}

# Convenience constants in internal units, like Geant4's CLHEP units.
nm, um, mm, cm, m = LENGTH["nm"], LENGTH["um"], LENGTH["mm"], LENGTH["cm"], LENGTH["m"]
eV, keV, MeV = ENERGY["eV"], ENERGY["keV"], ENERGY["MeV"]

_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*\*?\s*([^\s\d].*?)?\s*$")


def parse_quantity(value: object, dimension: str, name: str | None = None) -> float:
    """Return ``value`` in internal units.

    ``value`` is a string ``"<number> <unit>"`` (``"5.3 MeV"``, ``"20nm"``, ``"1e-3 mm"``).
    A bare number is refused, because a silent unit choice is the classic source of factors
    of 1000 in simulations; the error says which units are accepted.
    """
    units = DIMENSIONS[dimension]
    accepted = ", ".join(units)
    example = next(iter(units)) if dimension != "energy" else "MeV"
    prefix = f"{name}: " if name else ""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ConfigError(f"{prefix}expected a {dimension} such as '1 {example}', got {value!r}")
    match = _QUANTITY.match(str(value))
    if match and match.group(2) is None:
        raise ConfigError(
            f"{prefix}{value!r} has no unit; write '<number> <unit>' with unit one of: {accepted}"
        )
    if not match:
        raise ConfigError(
            f"{prefix}cannot read {value!r} as a {dimension}; write '<number> <unit>' with unit "
            f"one of: {accepted}"
        )
    number, unit = float(match.group(1)), match.group(2)
    if unit not in units:
        raise ConfigError(
            f"{prefix}unknown {dimension} unit {unit!r} in {value!r}; use one of: {accepted}"
        )
    result = number * units[unit]
    if not math.isfinite(result):
        raise ConfigError(f"{prefix}{value!r} is not a finite {dimension}")
    return result


def format_quantity(value: float, dimension: str, unit: str) -> str:
    """Format an internal-unit value as ``"<number> <unit>"`` (the inverse of
    :func:`parse_quantity`)."""
    return f"{value / DIMENSIONS[dimension][unit]:.12g} {unit}"
