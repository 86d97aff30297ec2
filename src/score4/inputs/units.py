"""Quantities with units.

score4 works in Geant4's internal units: millimetre, MeV, nanosecond, radian. Configuration
files and the CLI take strings such as ``"5.3 MeV"`` or ``"20 nm"``; :func:`parse_quantity`
turns them into floats in internal units and says clearly what is wrong otherwise.
"""

from __future__ import annotations

import math
import re

from score4.errors import ConfigError, brief

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
    "day": 86400e9,
    # the Julian year (365.25 d): "y" and "yr" (the year of live times in the field's papers)
    "y": 365.25 * 86400e9,
    "yr": 365.25 * 86400e9,
}
ANGLE = {"rad": 1.0, "mrad": 1e-3, "deg": math.pi / 180.0}
AREA = {"nm2": 1e-12, "um2": 1e-6, "mm2": 1.0, "cm2": 100.0, "m2": 1e6}
# Densities are kept in g/cm3 (not Geant4's internal mass unit), the unit of NIST tables,
# Geant4's printouts and SRIM; multiply by Geant4's ``g / cm3`` when building a G4Material.
DENSITY = {"g/cm3": 1.0, "mg/cm3": 1e-3, "kg/m3": 1e-3, "g/m3": 1e-6}

# Activities and masses are not Geant4 quantities: they are kept in Bq and kg (a template's
# counts/(keV kg day) is built from them), areas in mm2 and volumes in mm3 as everywhere else.
MASS = {"ug": 1e-9, "mg": 1e-6, "g": 1e-3, "kg": 1.0, "t": 1e3}
VOLUME = {"um3": 1e-9, "mm3": 1.0, "cm3": 1e3, "l": 1e6, "m3": 1e9}
ACTIVITY = {"nBq": 1e-9, "uBq": 1e-6, "µBq": 1e-6, "mBq": 1e-3, "Bq": 1.0, "kBq": 1e3, "MBq": 1e6}
# per area (Bq/mm2), per mass (Bq/kg), per volume (Bq/mm3): every prefix with every unit
SURFACE_ACTIVITY = {
    f"{a}/{b}": fa / AREA[b] for a, fa in ACTIVITY.items() for b in ("mm2", "cm2", "m2")
}
SPECIFIC_ACTIVITY = {f"{a}/{b}": fa / MASS[b] for a, fa in ACTIVITY.items() for b in ("g", "kg")}
ACTIVITY_DENSITY = {
    f"{a}/{b}": fa / VOLUME[b] for a, fa in ACTIVITY.items() for b in ("mm3", "cm3", "l", "m3")
}

DIMENSIONS: dict[str, dict[str, float]] = {
    "length": LENGTH,
    "energy": ENERGY,
    "time": TIME,
    "angle": ANGLE,
    "area": AREA,
    "density": DENSITY,
    "mass": MASS,
    "volume": VOLUME,
    "activity": ACTIVITY,
    "surface activity": SURFACE_ACTIVITY,
    "specific activity": SPECIFIC_ACTIVITY,
    "activity density": ACTIVITY_DENSITY,
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
    number, unit = float(match.group(1)), _tidy_unit(match.group(2))
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


def split_quantity(value: object) -> tuple[float, str] | None:
    """``(number, unit)`` of ``"<number> <unit>"`` as written (unit tidied as parsing does), or
    None when ``value`` is not of that form."""
    match = _QUANTITY.match(str(value))
    if not match or match.group(2) is None:
        return None
    return float(match.group(1)), _tidy_unit(match.group(2))


def _tidy_unit(unit: str) -> str:
    """``"mBq / cm^2"`` reads as ``"mBq/cm2"``: spaces around a slash and powers' carets go."""
    return re.sub(r"\s*/\s*", "/", unit).replace("^", "")


#: How an activity is given: per area (surface sources), per mass or per volume (bulk sources),
#: or in total (Bq), with the dimension of :data:`DIMENSIONS` that reads it.
ACTIVITY_KINDS = {
    "area": "surface activity",
    "mass": "specific activity",
    "volume": "activity density",
    "total": "activity",
}


def parse_activity(value: object, name: str = "activity") -> tuple[str, float]:
    """``(kind, value)`` of an activity: kind ``"area"`` (Bq/mm2), ``"mass"`` (Bq/kg),
    ``"volume"`` (Bq/mm3) or ``"total"`` (Bq).

    ``"1 mBq/cm2"`` is ``("area", 1e-5)``; ``"5 mBq/kg"`` is ``("mass", 5e-3)``. Whether the kind
    fits a source is the caller's rule (:func:`score4.analysis.templates.total_activity`).
    """
    text = str(value)
    match = _QUANTITY.match(text) if isinstance(value, (str, int, float)) else None
    unit = _tidy_unit(match.group(2)) if match and match.group(2) else None
    for kind, dimension in ACTIVITY_KINDS.items():
        if unit in DIMENSIONS[dimension]:
            return kind, parse_quantity(value, dimension, name)
    if match and unit is None:
        raise ConfigError(
            f"{name}: {value!r} has no unit; write e.g. '1 mBq/cm2' (per area, surface sources), "
            "'5 mBq/kg' (per mass, bulk sources) or '2 Bq' (in total)"
        )
    raise ConfigError(
        f"{name}: cannot read {value!r} as an activity; write '<number> <unit>' with a unit such "
        "as Bq/cm2, mBq/m2, nBq/cm2 (per area), mBq/kg (per mass), Bq/cm3 (per volume) or Bq"
    )


# Units a readable value is shown in, smallest first (a number between 1 and 1000 in one of them).
_READABLE = {
    "length": ("pm", "nm", "um", "mm", "m", "km"),
    "energy": ("eV", "keV", "MeV", "GeV", "TeV"),
    "time": ("ps", "ns", "us", "ms", "s"),
    "angle": ("deg",),
    "area": ("nm2", "um2", "mm2", "cm2", "m2"),
    "density": ("g/cm3",),
    "mass": ("ug", "mg", "g", "kg", "t"),
    "volume": ("um3", "mm3", "cm3", "m3"),
    "activity": ("nBq", "uBq", "mBq", "Bq", "kBq", "MBq"),
    "surface activity": ("nBq/cm2", "uBq/cm2", "mBq/cm2", "Bq/cm2", "kBq/cm2"),
    "specific activity": ("nBq/kg", "uBq/kg", "mBq/kg", "Bq/kg", "kBq/kg"),
    "activity density": ("nBq/cm3", "uBq/cm3", "mBq/cm3", "Bq/cm3", "kBq/cm3"),
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


def count_text(n: float, word: str, plural: str | None = None) -> str:
    """``1 event``, ``2 events``, ``0 events`` (``word`` singular; ``plural`` default word + s)."""
    return f"{n} {word}" if n == 1 else f"{n} {plural or word + 's'}"


def length_text(value_mm: float) -> str:
    """A length in mm as readable text (:func:`format_readable`)."""
    return format_readable(value_mm, "length")
