"""Quantities with units.

score4 works in Geant4's internal units: millimetre, MeV, nanosecond, radian. Configuration
files and the CLI take strings such as ``"5.3 MeV"`` or ``"20 nm"``; :func:`parse_quantity`
turns them into floats in internal units and says clearly what is wrong otherwise.
"""

from __future__ import annotations

import math
import re

from .errors import ConfigError, brief

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
# decay times since deposition reach years: min, h, d and the Julian year y (365.25 d)
TIME = {
    "ps": 1e-3,
    "ns": 1.0,
    "us": 1e3,
    "µs": 1e3,
    "ms": 1e6,
    "s": 1e9,
    "min": 60e9,
    "h": 3600e9,
    "d": 86400e9,
    "y": 365.25 * 86400e9,
}
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
    shown = brief(value)
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise ConfigError(f"{prefix}expected a {dimension} such as '1 {example}', got {shown}")
    match = _QUANTITY.match(str(value))
    if match and match.group(2) is None:
        raise ConfigError(
            f"{prefix}{shown} has no unit; write '<number> <unit>' with unit one of: {accepted}"
        )
    if not match:
        raise ConfigError(
            f"{prefix}cannot read {shown} as a {dimension}; write '<number> <unit>' with unit "
            f"one of: {accepted}"
        )
    number, unit = float(match.group(1)), match.group(2)
    if unit not in units:
        raise ConfigError(
            f"{prefix}unknown {dimension} unit {brief(unit)} in {shown}; use one of: {accepted}"
        )
    result = number * units[unit]
    if not math.isfinite(result):
        raise ConfigError(f"{prefix}{shown} is not a finite {dimension}")
    return result


_COUNT = re.compile(r"^\s*([-+]?)(\d+(?:_\d+)*)?(?:\.(\d*))?(?:[eE]([-+]?\d+))?\s*$")


def parse_count(value: object, name: str | None = None) -> int:
    """A whole number written as ``1000``, ``1e6``, ``2.5e5`` or ``1_000_000`` (YAML or CLI).

    YAML reads ``1e6`` as a string (its floats need a dot), and a count like ``events: 1e6``
    should mean what ``--events 1e6`` means. Floats must be whole numbers; anything else is a
    :class:`ConfigError` naming ``name`` and the value.
    """
    prefix = f"{name}: " if name else ""
    if isinstance(value, bool):
        raise ConfigError(f"{prefix}takes a whole number, not {str(value).lower()}")
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        if not math.isfinite(value) or not value.is_integer():
            raise ConfigError(f"{prefix}takes a whole number, got {brief(value)}")
        return int(value)
    text = str(value) if isinstance(value, str) else None
    match = _COUNT.match(text) if text is not None and len(text) < 40 else None
    if match is None or not (match.group(2) or match.group(3)):
        raise ConfigError(f"{prefix}takes a whole number such as 1000 or 1e6, got {brief(value)}")
    sign = -1 if match.group(1) == "-" else 1
    whole, frac, exp = match.group(2) or "0", match.group(3) or "", int(match.group(4) or 0)
    if abs(exp) > 30:
        raise ConfigError(f"{prefix}{brief(value)} is not a sensible count")
    digits, exp = int((whole + frac).replace("_", "")), exp - len(frac)
    if exp >= 0:
        return sign * digits * 10**exp
    number, rest = divmod(digits, 10**-exp)
    if rest:
        raise ConfigError(f"{prefix}takes a whole number, got {brief(value)}")
    return sign * number


def format_quantity(value: float, dimension: str, unit: str) -> str:
    """Format an internal-unit value as ``"<number> <unit>"`` (the inverse of
    :func:`parse_quantity`)."""
    return f"{value / DIMENSIONS[dimension][unit]:.12g} {unit}"


# Units a readable value is shown in, smallest first (a number between 1 and 1000 in one of them).
_READABLE = {
    "length": ("pm", "nm", "um", "mm", "m", "km"),
    "energy": ("eV", "keV", "MeV", "GeV", "TeV"),
    "time": ("ps", "ns", "us", "ms", "s"),
    "angle": ("deg",),
    "area": ("nm2", "um2", "mm2", "cm2", "m2"),
    "density": ("g/cm3",),
}


def format_readable(value: float, dimension: str, digits: int = 6) -> str:
    """An internal-unit value for people: ``1e-05`` mm is ``"10 nm"``, ``0.00019999999999999998``
    mm is ``"200 nm"`` (``digits`` significant digits, the unit that gives a number from 1 to 1000).
    """
    value = float(value)
    units = DIMENSIONS[dimension]
    names = _READABLE[dimension]
    if not math.isfinite(value) or value == 0:
        unit = "mm" if dimension == "length" else ("MeV" if dimension == "energy" else names[0])
        return f"{value:g} {unit}"
    chosen = names[0]
    for name in names:
        if abs(value) / units[name] >= 1 - 1e-12:
            chosen = name
    number = float(f"{value / units[chosen]:.{digits}g}")
    return f"{number:g} {chosen}" if abs(number) < 1e6 else f"{number:.{digits}g} {chosen}"


def length_text(value_mm: float) -> str:
    """A length in mm as readable text (:func:`format_readable`)."""
    return format_readable(value_mm, "length")


def energy_text(value_mev: float) -> str:
    """An energy in MeV as readable text (:func:`format_readable`)."""
    return format_readable(value_mev, "energy")
