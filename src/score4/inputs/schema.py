"""Shared pieces of the validated YAML schemas: a strict frozen base model and unit-carrying types.

Every quantity with a dimension is written with its unit ("5.3 MeV", "3 cm") and stored in
Geant4 internal units (mm, MeV). Both the run configuration (:mod:`score4.inputs.config`) and the
surface descriptions (:mod:`score4.surface.spec`) build on these.
"""

from __future__ import annotations

import contextlib
import difflib
import math
import types
from collections.abc import Callable
from dataclasses import dataclass
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

from score4.errors import ConfigError, brief

from . import limits
from .units import format_readable, parse_count, parse_quantity

_INTERNAL_UNIT = {"length": "mm", "energy": "MeV", "density": "g/cm3", "time": "ns"}

# The limits themselves, with their reasons, live in score4.inputs.limits (one place for
# all of them).
MAX_LENGTH, MIN_LENGTH, MAX_ENERGY = limits.MAX_LENGTH, limits.MIN_LENGTH, limits.MAX_ENERGY


def _quantity(dimension: str, positive: bool = False, non_negative: bool = False):
    """Parse "<number> <unit>", check it against the physical range; name the value as written."""

    def parse(value: object) -> float:
        v = parse_quantity(value, dimension)
        shown = brief(value) if isinstance(value, str) else format_readable(v, dimension)
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
                    f"{shown} is shorter than 10 pm, the smallest size Geant4 builds solids of "
                    "(it aborts below 4 pm) and far below an atom's"
                )
        if dimension == "energy" and abs(v) > MAX_ENERGY:
            raise ValueError(
                f"{shown} is above 100 TeV, the top of Geant4's electromagnetic physics tables"
            )
        if dimension == "density" and not limits.MIN_DENSITY <= v <= limits.MAX_DENSITY:
            raise ValueError(
                f"{shown} is outside 1e-12 ... 30 g/cm3: osmium, the densest element, is 22.6 "
                "g/cm3 (kg/m3 written as g/cm3?), and below 1e-12 g/cm3 a material is vacuum "
                "(use G4_Galactic)"
            )
        return v

    parse.dimension = dimension  # type: ignore[attr-defined]  # read by _quantity_kind
    return BeforeValidator(parse)


def quantity(
    value: object, dimension: str, label: str, positive: bool = False, non_negative: bool = False
) -> float:
    """A command-line quantity ("2 nm") in internal units, under the limits of the schema's
    quantity types (a ConfigError starting with ``label``, e.g. "--thickness")."""
    parse = _quantity(dimension, positive, non_negative).func
    try:
        return float(parse(value))
    except ValueError as err:
        raise ConfigError(f"{label}: {err}") from None


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
PositiveLength = Annotated[float, _quantity("length", positive=True), _with_unit("length")]
NonNegativeLength = Annotated[float, _quantity("length", non_negative=True), _with_unit("length")]
PositiveEnergy = Annotated[float, _quantity("energy", positive=True), _with_unit("energy")]
NonNegativeEnergy = Annotated[float, _quantity("energy", non_negative=True), _with_unit("energy")]
# times are kept in ns (Geant4's internal unit; see score4.inputs.units.TIME)
NonNegativeTime = Annotated[float, _quantity("time", non_negative=True), _with_unit("time")]
# densities are kept in g/cm3 (see score4.inputs.units.DENSITY)
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


@dataclass(frozen=True)
class Condition:
    """A test on another key's value for :attr:`StrictModel.used_only_with` (beyond a choice list).

    ``text`` completes "used only with <key> ..." (``"given"``, ``"above 0"``).
    """

    test: Callable[[Any], bool]
    text: str

    def __call__(self, value: object) -> bool:
        try:
            return bool(self.test(value))
        except TypeError:
            return False


#: The other key is given (not null).
GIVEN = Condition(lambda v: v is not None, "given")
#: The other key is a number above 0.
ABOVE_ZERO = Condition(lambda v: v is not None and v > 0, "above 0")

# One rule of used_only_with: (other key, choices or a Condition); several rules: any of them.
Rule = tuple[str, "tuple[object, ...] | Condition"]


def _rules(declared: Any) -> tuple[Rule, ...]:
    """The rules of one used_only_with entry: one (key, choices) pair or a tuple of them."""
    return (declared,) if isinstance(declared[0], str) else tuple(declared)


def _matches(value: object, choices: tuple[object, ...] | Condition) -> bool:
    if isinstance(choices, Condition):
        return choices(value)
    return any(value == c and isinstance(value, bool) == isinstance(c, bool) for c in choices)


class StrictModel(BaseModel):
    """Unknown keys are errors (a typo never silently falls back to a default); values are frozen.

    Before any field is read: an unknown key is named with the closest valid key; keys listed
    together in :attr:`exclusive_keys` are refused together; a boolean (``true``/``false``) is
    refused where the field takes no boolean (YAML's ``seed: true`` would otherwise become 1);
    a whole number written ``1e6`` (a string to YAML) is read as 1000000. After the fields: a
    key of :attr:`used_only_with` given under options that ignore it is refused.
    """

    # defer_build: a model's validator is built when it first validates, not when the class is
    # made; a worker process only unpickles validated models and never pays for it
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    #: Pairs of keys that say the same thing in two ways; giving both (with different values)
    #: is an error.
    exclusive_keys: ClassVar[tuple[tuple[str, str], ...]] = ()

    #: Keys that mean something only under some options of their model:
    #: ``{key: (other_key, (value, ...))}``, or a :class:`Condition` instead of the values
    #: (``GIVEN``, ``ABOVE_ZERO``), or a tuple of such pairs when any of them makes the key
    #: used (``((heavy_ions, (trim,)), (alphas, (trim,)))``). A key given (not null) while no
    #: rule holds would be ignored silently: it is an error. ``other_key`` is read as given,
    #: else its default, through :meth:`option_values` (which a model overrides for options
    #: that resolve later, e.g. ``solid: auto``). Declare every new option-dependent key here;
    #: the rule needs no code of its own.
    used_only_with: ClassVar[dict[str, Any]] = {}

    def option_values(self, key: str, root: BaseModel | None) -> tuple[object, ...] | None:
        """The values option ``key`` stands for; None while that needs the whole description.

        ``root`` is None while this model is validated alone, and the root model (the run
        configuration) when :func:`check_option_keys` checks again with everything known.
        """
        return (getattr(self, key),)

    @model_validator(mode="before")
    @classmethod
    def _strict_keys(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
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
        counts = {}
        for name, field in fields.items():
            value = data.get(name)
            _check_text(name, value, _admits_path(field.annotation))
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
            if isinstance(value, str) and _is_count(field.annotation):
                try:
                    counts[name] = parse_count(value)
                except ConfigError as err:
                    raise PydanticCustomError(
                        "count", "{message}", {"key": name, "message": str(err)}
                    ) from None
        return {**data, **counts} if counts else data

    @model_validator(mode="after")
    def _used_keys(self, info: ValidationInfo) -> Any:
        if (info.context or {}).get("stored"):  # written by score4 with every key filled in
            return self
        problem = unused_key(self, None)
        if problem is not None:
            key, message = problem
            raise PydanticCustomError("unused_key", "{message}", {"key": key, "message": message})
        return self


def _check_text(name: str, value: object, path: bool) -> None:
    """Refuse names (and mapping keys) longer than MAX_NAME, file names longer than MAX_PATH."""
    longest = limits.MAX_PATH if path else limits.MAX_NAME
    texts = [value] if isinstance(value, str) else []
    if isinstance(value, dict):
        texts += [k for k in value if isinstance(k, str)]
    for text in texts:
        if len(text) > longest:
            raise PydanticCustomError(
                "too_long",
                "{message}",
                {
                    "key": name,
                    "message": f"takes at most {longest} characters, got {len(text)} "
                    f"({brief(text, 40)})",
                },
            )


def _admits_path(tp: Any) -> bool:
    origin = get_origin(tp)
    if origin is Annotated:
        return _admits_path(get_args(tp)[0])
    if origin in (Union, types.UnionType):
        return any(_admits_path(a) for a in get_args(tp))
    return tp is Path


def unused_key(model: StrictModel, root: BaseModel | None) -> tuple[str, str] | None:
    """(key, message) of the first key of ``model`` that its options ignore, or None.

    With ``root`` None, rules on options not known yet (:meth:`StrictModel.option_values`
    returns None) pass; :func:`check_option_keys` checks them with the whole description.
    """
    for key, declared in model.used_only_with.items():
        if key not in model.model_fields_set or getattr(model, key) is None:
            continue
        rules, seen, unknown = _rules(declared), [], False
        for other, choices in rules:
            values = model.option_values(other, root)
            if values is None:
                unknown = True
                continue
            if any(_matches(v, choices) for v in values):
                break
            seen.append(_here(model, other, values))
        else:
            if unknown:
                continue
            wanted = " or ".join(_wanted(other, choices) for other, choices in rules)
            others = " or ".join(dict.fromkeys(other for other, _ in rules))
            return key, (
                f"used only with {wanted} (here {', '.join(seen)}); remove {key} or change {others}"
            )
    return None


def _wanted(other: str, choices: tuple[object, ...] | Condition) -> str:
    if isinstance(choices, Condition):
        return f"{other} {choices.text}"
    return f"{other}: " + " or ".join(_shown_choice(c) for c in choices)


def _here(model: StrictModel, other: str, values: tuple[object, ...]) -> str:
    written = getattr(model, other, None)
    shown = "/".join(dict.fromkeys(_shown_choice(v) for v in values))
    if values == (written,):
        return f"{other} is {'not given' if written is None else shown}"
    return f"{other} {_shown_choice(written)} is {shown}"


def check_option_keys(root: BaseModel) -> None:
    """Check :attr:`StrictModel.used_only_with` again in every model under ``root``, with
    ``root`` known (options such as ``solid: auto`` that depend on other sections resolve now).

    Raises a ValueError naming the key's full path.
    """
    for path, model in _models(root, ""):
        problem = unused_key(model, root)
        if problem is not None:
            key, message = problem
            raise PydanticCustomError(
                "unused_key", "{message}", {"key": f"{path}{key}", "message": message}
            )


def _models(value: object, path: str):
    """(path prefix, model) of every StrictModel in a validated tree, depth first."""
    if isinstance(value, StrictModel):
        yield path, value
        for name in type(value).model_fields:
            yield from _models(getattr(value, name), f"{path}{name}.")
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            yield from _models(item, f"{path}{i}.")
    elif isinstance(value, dict):
        for k, item in value.items():
            yield from _models(item, f"{path}{k}.")


def input_paths(root: BaseModel) -> dict[str, Path]:
    """``{"the file of <key path>": path}`` for every file a validated description reads (every
    :data:`ConfigPath` value), so that no output of a command replaces one of them."""
    found = {}
    for path, model in _models(root, ""):
        for name in type(model).model_fields:
            value = getattr(model, name)
            if isinstance(value, Path):
                found[f"the file of {path}{name}"] = value
            elif isinstance(value, list | tuple):
                for k, item in enumerate(value):
                    if isinstance(item, Path):
                        found[f"the file of {path}{name}.{k}"] = item
    return found


def _is_count(tp: Any) -> bool:
    """True for int fields (also Optional or constrained): a string there is read as a count."""
    origin = get_origin(tp)
    if origin is Annotated:
        return _is_count(get_args(tp)[0])
    if origin in (Union, types.UnionType):
        members = [a for a in get_args(tp) if a is not type(None)]
        return bool(members) and all(_is_count(a) for a in members)
    return tp is int


def _shown_choice(value: object) -> str:
    """A choice as written in YAML (true/false, null, plain names)."""
    if isinstance(value, bool):
        return _bool_text(value)
    return "null" if value is None else str(value) if isinstance(value, str) else _shown(value)


def _unknown(key: object, fields: dict) -> str:
    short = isinstance(key, str) and len(key) <= 100
    close = difflib.get_close_matches(key, list(fields), n=1, cutoff=0.6) if short else []
    if close:
        return f"unknown key; did you mean '{close[0]}'?"
    return f"unknown key; valid keys here: {', '.join(fields)}"


# Tags of tagged unions that pydantic puts into error locations; they are not keys the user wrote.
UNION_TAGS = frozenset(
    {
        "spikes",
        "random",
        "measured",
        "surface-file",
        "box-target",
        "gdml-target",
        "chain",
        "nuclide",
    }
)
# Errors about the keys themselves come first: a typo is the cause of a "Field required" next to it.
_KEY_ERRORS = ("unknown_key", "exclusive_keys", "extra_forbidden")
# Errors whose message says all; the value (often the whole mapping) is not repeated.
_NO_VALUE = ("missing", *_KEY_ERRORS, "unused_key", "bool_not_allowed", "count", "too_long")


def _shown(value: object) -> str:
    """A value as the user would write it: no numpy wrappers, no float noise."""
    if isinstance(value, bool):
        return _bool_text(value)
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # numpy scalars
        with contextlib.suppress(TypeError, ValueError):
            value = value.item()
    if isinstance(value, float):
        return f"{value:.6g}" if math.isfinite(value) else str(value)
    if isinstance(value, Path):  # as written in the YAML, not PosixPath('w.gdml')
        return str(value)
    return brief(value)


def _key_text(key: object) -> str:
    """A key of the error's path, as written (cut if it is unbounded input)."""
    if isinstance(key, str) and len(key) <= 60:
        return key
    if isinstance(key, int) and not isinstance(key, bool) and abs(key) < 10**18:
        return str(key)
    return brief(key)


def _written_path(loc: tuple, data: object) -> list:
    """The keys of ``loc`` the user wrote: following ``data`` along ``loc``, an element that is
    not a key (or index) of the value reached is a union tag pydantic added (a surface named
    ``random`` keeps its name; the tag ``random`` after it goes)."""
    path, node = [], data
    for p in loc:
        is_key = isinstance(node, dict) and p in node
        is_index = (
            isinstance(node, (list, tuple)) and isinstance(p, int) and -len(node) <= p < len(node)
        )
        if is_key or is_index:
            path.append(p)
            node = node[p]  # type: ignore[index]
        elif p not in UNION_TAGS:
            path.append(p)
            node = None
    return path


def describe_validation_error(err: ValidationError, origin: str, data: object = None) -> str:
    """The first problem of a pydantic error as one line: origin, key path, rule, value.

    ``data``: the validated input, to tell the keys the user wrote from union tags.
    """
    errors = err.errors()
    first = next((e for e in errors if e["type"] in _KEY_ERRORS), errors[0])
    raw = tuple(first["loc"])
    written = (
        _written_path(raw, data) if data is not None else [p for p in raw if p not in UNION_TAGS]
    )
    path = [_key_text(p) for p in written]
    ctx = first.get("ctx") or {}
    if "key" in ctx:
        path.append(_key_text(ctx["key"]))
    loc = ".".join(path)
    msg = first["msg"].removeprefix("Value error, ")
    if first["type"] == "extra_forbidden":
        msg = "unknown key (check the spelling; see the config reference)"
    value = first.get("input")
    shown = ""
    if first["type"] not in _NO_VALUE and not isinstance(value, dict):
        text = _shown(value)
        if text not in msg and (not isinstance(value, str) or value not in msg):
            shown = f" (got {text})"
    more = f" [+{len(errors) - 1} more problem(s)]" if len(errors) > 1 else ""
    where = f"{origin}: {loc}: " if loc else f"{origin}: "
    return f"{where}{msg}{shown}{more}"


def _resolve_path(value: Path, info: ValidationInfo) -> Path:
    base = (info.context or {}).get("base_dir")
    return value if value.is_absolute() or base is None else Path(base) / value


# A file path; relative paths are taken relative to the config file's folder.
ConfigPath = Annotated[Path, AfterValidator(_resolve_path)]
