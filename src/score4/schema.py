"""Shared pieces of the validated YAML schemas: a strict frozen base model and unit-carrying types.

Every quantity with a dimension is written with its unit ("5.3 MeV", "3 cm") and stored in
Geant4 internal units (mm, MeV). Both the run configuration (:mod:`score4.config`) and the
surface descriptions (:mod:`score4.surface.spec`) build on these.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PlainSerializer,
    ValidationError,
    ValidationInfo,
)

from .units import parse_quantity

_INTERNAL_UNIT = {"length": "mm", "energy": "MeV", "density": "g/cm3"}


def _quantity(dimension: str):
    return BeforeValidator(lambda v: parse_quantity(v, dimension))


def _with_unit(dimension: str):
    # JSON dumps keep the unit, so a stored description validates again as it is.
    unit = _INTERNAL_UNIT[dimension]
    return PlainSerializer(lambda v: f"{v!r} {unit}", return_type=str, when_used="json")


Length = Annotated[float, _quantity("length"), _with_unit("length")]
Energy = Annotated[float, _quantity("energy"), _with_unit("energy")]
PositiveLength = Annotated[float, _quantity("length"), Field(gt=0), _with_unit("length")]
NonNegativeLength = Annotated[float, _quantity("length"), Field(ge=0), _with_unit("length")]
PositiveEnergy = Annotated[float, _quantity("energy"), Field(gt=0), _with_unit("energy")]
# densities are kept in g/cm3 (see score4.units.DENSITY)
PositiveDensity = Annotated[float, _quantity("density"), Field(gt=0), _with_unit("density")]
Vector3 = tuple[Length, Length, Length]
Size3 = tuple[PositiveLength, PositiveLength, PositiveLength]


class StrictModel(BaseModel):
    """Unknown keys are errors (a typo never falls back to a default); values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


# Tags of tagged unions that pydantic puts into error locations; they are not keys the user wrote.
UNION_TAGS = frozenset({"spikes", "random", "measured", "surface-file"})


def describe_validation_error(err: ValidationError, origin: str) -> str:
    """The first problem of a pydantic error as one line: origin, key path, rule, value."""
    first = err.errors()[0]
    loc = ".".join(str(p) for p in first["loc"] if p not in UNION_TAGS)
    msg = first["msg"].removeprefix("Value error, ")
    if first["type"] == "extra_forbidden":
        msg = "unknown key (check the spelling; see the config reference)"
    value = first.get("input")
    shown = "" if first["type"] == "missing" or isinstance(value, dict) else f" (got {value!r})"
    more = f" [+{len(err.errors()) - 1} more problem(s)]" if len(err.errors()) > 1 else ""
    where = f"{origin}: {loc}: " if loc else f"{origin}: "
    return f"{where}{msg}{shown}{more}"


def _resolve_path(value: Path, info: ValidationInfo) -> Path:
    base = (info.context or {}).get("base_dir")
    return value if value.is_absolute() or base is None else Path(base) / value


# A file path; relative paths are taken relative to the config file's folder.
ConfigPath = Annotated[Path, AfterValidator(_resolve_path)]
