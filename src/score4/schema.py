"""Shared pieces of the validated YAML schemas: a strict frozen base model and unit-carrying types.

Every quantity with a dimension is written with its unit ("5.3 MeV", "3 cm") and stored in
Geant4 internal units (mm, MeV). Both the run configuration (:mod:`score4.config`) and the
surface descriptions (:mod:`score4.surface.spec`) build on these.
"""

from __future__ import annotations

import contextlib
import difflib
import math
import types
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Union, get_args, get_origin

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    PlainSerializer,
    ValidationError,
    ValidationInfo,
    model_validator,
)
from pydantic_core import PydanticCustomError

from .units import format_readable, parse_quantity

_INTERNAL_UNIT = {"length": "mm", "energy": "MeV", "density": "g/cm3", "time": "ns"}

#: Largest length (mm) anywhere in a description: 100 m. The largest rare-event detectors and
#: their shields are ~10 m; a larger value is a unit slip ("10 km" for "10 mm"). Geant4's
#: surface tolerance is absolute (1e-9 mm), and so is double precision's reach at 100 m (2e-11 mm).
MAX_LENGTH = 100e3
#: Smallest positive length (mm): 1 pm, Geant4's surface tolerance (kCarTolerance = 1e-9 mm);
#: a shorter size or depth has no meaning in the geometry.
MIN_LENGTH = 1e-9
#: Largest energy (MeV): 100 TeV, the top of Geant4's electromagnetic physics tables
#: (G4EmParameters::MaxKinEnergy); nothing above it is tracked as it should be.
MAX_ENERGY = 100e6


def _quantity(dimension: str, positive: bool = False, non_negative: bool = False):
    """Parse "<number> <unit>", check it against the physical range; name the value as written."""

    def parse(value: object) -> float:
        v = parse_quantity(value, dimension)
        shown = f"'{value}'" if isinstance(value, str) else format_readable(v, dimension)
        if positive and not v > 0:
            raise ValueError(f"must be greater than 0, got {shown}")
        if non_negative and v < 0:
            raise ValueError(f"must be 0 or more, got {shown}")
        if dimension == "length":
            if abs(v) > MAX_LENGTH:
                raise ValueError(
                    f"{shown} is longer than 100 m, score4's limit for any length (a unit slip?)"
                )
            if positive and v < MIN_LENGTH:
                raise ValueError(
                    f"{shown} is shorter than 1 pm, Geant4's surface tolerance (a unit slip?)"
                )
        if dimension == "energy" and abs(v) > MAX_ENERGY:
            raise ValueError(
                f"{shown} is above 100 TeV, the top of Geant4's electromagnetic physics tables"
            )
        return v

    parse.dimension = dimension  # type: ignore[attr-defined]  # read by _quantity_kind
    return BeforeValidator(parse)


_EXAMPLE = {"length": "5 um", "energy": "5.3 MeV", "density": "6.02 g/cm3", "time": "180 d"}


def _quantity_kind(metadata) -> str | None:
    """ "a length such as '5 um'" for a quantity type's metadata, else None."""
    for m in metadata:
        dimension = getattr(getattr(m, "func", None), "dimension", None)
        if isinstance(m, BeforeValidator) and dimension:
            return f"a {dimension} such as '{_EXAMPLE.get(dimension, '1 ' + dimension)}'"
    return None


def _with_unit(dimension: str):
    # JSON dumps keep the unit, so a stored description validates again as it is.
    unit = _INTERNAL_UNIT[dimension]
    return PlainSerializer(lambda v: f"{v!r} {unit}", return_type=str, when_used="json")


Length = Annotated[float, _quantity("length"), _with_unit("length")]
Energy = Annotated[float, _quantity("energy"), _with_unit("energy")]
PositiveLength = Annotated[float, _quantity("length", positive=True), _with_unit("length")]
NonNegativeLength = Annotated[float, _quantity("length", non_negative=True), _with_unit("length")]
PositiveEnergy = Annotated[float, _quantity("energy", positive=True), _with_unit("energy")]
NonNegativeEnergy = Annotated[float, _quantity("energy", non_negative=True), _with_unit("energy")]
# times are kept in ns (Geant4's internal unit; see score4.units.TIME)
NonNegativeTime = Annotated[float, _quantity("time", non_negative=True), _with_unit("time")]
# densities are kept in g/cm3 (see score4.units.DENSITY)
PositiveDensity = Annotated[float, _quantity("density", positive=True), _with_unit("density")]
Vector3 = tuple[Length, Length, Length]
Size3 = tuple[PositiveLength, PositiveLength, PositiveLength]


def _admits_bool(tp: Any) -> bool:
    """True if a field of type ``tp`` may hold true/false."""
    if tp is bool or tp is Any or tp is object:
        return True
    origin = get_origin(tp)
    if origin is Annotated:
        return _admits_bool(get_args(tp)[0])
    if origin in (Union, types.UnionType):
        return any(_admits_bool(a) for a in get_args(tp))
    if origin is Literal:
        return any(isinstance(a, bool) for a in get_args(tp))
    return False


def _item_types(tp: Any) -> tuple:
    """Element types of list/tuple fields (through Optional and Annotated)."""
    origin = get_origin(tp)
    if origin is Annotated:
        return _item_types(get_args(tp)[0])
    if origin in (Union, types.UnionType):
        return tuple(t for a in get_args(tp) for t in _item_types(a))
    if origin in (list, tuple):
        return tuple(a for a in get_args(tp) if a is not Ellipsis)
    return ()


def _kind(tp: Any) -> str:
    """What a field of type ``tp`` takes, in words."""
    origin = get_origin(tp)
    if origin is Annotated:
        base, *meta = get_args(tp)
        return _quantity_kind(meta) or _kind(base)
    if origin in (Union, types.UnionType):
        kinds = [_kind(a) for a in get_args(tp) if a is not type(None)]
        return kinds[0] if len(kinds) == 1 else " or ".join(kinds)
    return {int: "a whole number", float: "a number", str: "a name", Path: "a file name"}.get(
        tp, "a value"
    )


def _bool_text(value: bool) -> str:
    return "true" if value else "false"


class StrictModel(BaseModel):
    """Unknown keys are errors (a typo never silently falls back to a default); values are frozen.

    Before any field is read: an unknown key is named with the closest valid key; keys listed
    together in :attr:`exclusive_keys` are refused together; a key of :attr:`used_only_with`
    given under a choice that ignores it is refused; a boolean (``true``/``false``) is
    refused where the field takes no boolean (YAML's ``seed: true`` would otherwise become 1).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    #: Pairs of keys that say the same thing in two ways; giving both (with different values)
    #: is an error.
    exclusive_keys: ClassVar[tuple[tuple[str, str], ...]] = ()

    #: Keys that mean something only under some choices of another key of the same model:
    #: ``{key: (other_key, (value, ...))}``. A key given (not null) while ``other_key`` (as
    #: written, else its default) holds another value would be ignored silently: it is an error.
    #: Declare every new option-dependent key here; the rule needs no code of its own.
    used_only_with: ClassVar[dict[str, tuple[str, tuple[object, ...]]]] = {}

    @model_validator(mode="before")
    @classmethod
    def _strict_keys(cls, data: Any, info: ValidationInfo) -> Any:
        if not isinstance(data, dict):
            return data
        # a stored description (model_dump of a validated one: every key filled in, also those
        # its options ignore) was checked when it was written: the used_only_with rule is skipped
        stored = bool((info.context or {}).get("stored"))
        fields = cls.model_fields
        for key in data:
            if key not in fields:
                raise PydanticCustomError(
                    "unknown_key", "{message}", {"key": key, "message": _unknown(key, fields)}
                )
        for a, b in cls.exclusive_keys:
            # equal values are harmless (and what a stored, filled-in description holds)
            if a in data and b in data and data[a] != data[b] and data[a] is not None:
                raise PydanticCustomError(
                    "exclusive_keys",
                    "{message}",
                    {
                        "key": b,
                        "message": f"give {a} or {b}, not both ({a} is short for both axes)",
                    },
                )
        for key, (other, choices) in cls.used_only_with.items():
            if data.get(key) is None or stored:
                continue
            chosen = data[other] if other in data else fields[other].default
            if chosen not in choices:
                wanted = " or ".join(_shown_choice(c) for c in choices)
                raise PydanticCustomError(
                    "unused_key",
                    "{message}",
                    {
                        "key": key,
                        "message": f"used only with {other}: {wanted} (here {other} is "
                        f"{_shown_choice(chosen)}); remove {key} or change {other}",
                    },
                )
        for name, field in fields.items():
            value = data.get(name)
            if isinstance(value, bool) and not _admits_bool(field.annotation):
                kind = _quantity_kind(field.metadata) or _kind(field.annotation)
                raise PydanticCustomError(
                    "bool_not_allowed",
                    "{message}",
                    {"key": name, "message": f"takes {kind}, not {_bool_text(value)}"},
                )
            items = _item_types(field.annotation)
            if isinstance(value, (list, tuple)) and items and not any(map(_admits_bool, items)):
                for i, item in enumerate(value):
                    if isinstance(item, bool):
                        raise PydanticCustomError(
                            "bool_not_allowed",
                            "{message}",
                            {
                                "key": f"{name}.{i}",
                                "message": f"takes {_kind(items[0])}, not {_bool_text(item)}",
                            },
                        )
        return data


def _shown_choice(value: object) -> str:
    """A choice as written in YAML (true/false, null, plain names)."""
    if isinstance(value, bool):
        return _bool_text(value)
    return "null" if value is None else str(value)


def _unknown(key: object, fields: dict) -> str:
    close = difflib.get_close_matches(str(key), list(fields), n=1, cutoff=0.6)
    if close:
        return f"unknown key; did you mean '{close[0]}'?"
    return f"unknown key; valid keys here: {', '.join(fields)}"


# Tags of tagged unions that pydantic puts into error locations; they are not keys the user wrote.
UNION_TAGS = frozenset(
    {"spikes", "random", "measured", "surface-file", "box-target", "gdml-target"}
)
# Errors about the keys themselves come first: a typo is the cause of a "Field required" next to it.
_KEY_ERRORS = ("unknown_key", "exclusive_keys", "unused_key", "extra_forbidden")


def _shown(value: object) -> str:
    """A value as the user would write it: no numpy wrappers, no float noise."""
    if isinstance(value, bool):
        return _bool_text(value)
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # numpy scalars
        with contextlib.suppress(TypeError, ValueError):
            value = value.item()
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    return repr(value)


def describe_validation_error(err: ValidationError, origin: str) -> str:
    """The first problem of a pydantic error as one line: origin, key path, rule, value."""
    errors = err.errors()
    first = next((e for e in errors if e["type"] in _KEY_ERRORS), errors[0])
    path = [str(p) for p in first["loc"] if p not in UNION_TAGS]
    ctx = first.get("ctx") or {}
    if "key" in ctx:
        path.append(str(ctx["key"]))
    loc = ".".join(path)
    msg = first["msg"].removeprefix("Value error, ")
    if first["type"] == "extra_forbidden":
        msg = "unknown key (check the spelling; see the config reference)"
    value = first.get("input")
    shown = ""
    if first["type"] not in ("missing", *_KEY_ERRORS, "bool_not_allowed") and not isinstance(
        value, dict
    ):
        text = _shown(value)
        if text not in msg and str(value) not in msg:
            shown = f" (got {text})"
    more = f" [+{len(errors) - 1} more problem(s)]" if len(errors) > 1 else ""
    where = f"{origin}: {loc}: " if loc else f"{origin}: "
    return f"{where}{msg}{shown}{more}"


def _resolve_path(value: Path, info: ValidationInfo) -> Path:
    base = (info.context or {}).get("base_dir")
    return value if value.is_absolute() or base is None else Path(base) / value


# A file path; relative paths are taken relative to the config file's folder.
ConfigPath = Annotated[Path, AfterValidator(_resolve_path)]
