"""Hypothesis strategies for the fuzz suite, derived from the schema and the command tree.

Nothing here names a configuration key or a command option: the strategies walk the pydantic
models of :class:`score4.inputs.config.RunConfig` (and the surface descriptions) and the click
commands of ``score4``, so a key or an option another branch adds is fuzzed without new code.

* :func:`documents`: run descriptions. Half are generated whole from the schema; half are a
  valid description (:data:`VALID`) with one to three values replaced, at paths taken from the
  schema, by values of the right type or by hostile ones (huge, tiny, negative, not finite,
  wrong type, unbounded strings, deep lists).
* :func:`command_lines`: ``score4`` command lines: a command, its arguments drawn from a pool
  of prepared files (and missing ones), its options with values of their click type or hostile.
"""

from __future__ import annotations

import copy
import itertools
import types
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import click
from hypothesis import strategies as st
from pydantic import BaseModel

from score4.inputs.config import RunConfig
from score4.inputs.schema import _quantity_kind
from score4.inputs.units import DIMENSIONS

#: A valid description the mutations start from: a rough face (its surface is built) and one
#: surface of each kind, named by its kind (mutations of a kind's keys go to its own entry).
VALID: dict = {
    "physics": "lite",
    "surfaces": {
        "spikes": {"kind": "spikes", "nx": 2, "ny": 2, "width": "5 um", "height": "2 um"},
        "random": {
            "kind": "random",
            "nx": 20,
            "ny": 10,
            "pitch": "1 um",
            "sq": "0.2 um",
            "corr_length": "2 um",
        },
        "measured": {"kind": "measured", "file": "g.txt"},
        "s": {"file": "s.s4s.h5"},
    },
    "targets": [
        {
            "name": "crystal",
            "material": "G4_Si",
            "size": ["20 um", "10 um", "1 mm"],
            "position": ["0 mm", "0 mm", "-0.5 mm"],
            "rough": [{"surface": "spikes"}],
        }
    ],
    "source": {"particle": "alpha", "energy": "5.3 MeV", "surface": {"volume": "crystal"}},
    "run": {"events": 20, "seed": 3},
}

#: Names that make references resolve (a target, a surface, materials, particles) or not.
NAMES = ["crystal", "s", "G4_Si", "G4_Galactic", "alpha", "e-", "Pb206", "Po210", "TeO2", "+z"]
#: File names of the fuzz folder (see test_fuzz.py); some exist, some do not.
FILES = [
    "c.yaml",
    "s.yaml",
    "s.s4s.h5",
    "v.h5",
    "r.h5",
    "g.txt",
    "depth.txt",
    "bad.yaml",
    "missing.yaml",
    "missing.h5",
    "dir",
    "out.h5",
    "out.png",
    "out.csv",
    "out.yaml",
    "out.s4s.h5",
    "m.mac",
]

_NUMBERS = [0, 1, -1, 2, 3, 7, 10, 100, 1000, 10**6, 10**12, 10**13, 2**63, 10**30, -(10**9)]
_REALS = [0.0, 1e-300, 1e-12, 2e-9, 1e-3, 0.5, 1.0, 5.3, 20.0, 1e3, 1e5, 1e30, -1.0, -1e-9]
_HOSTILE = st.one_of(
    st.none(),
    st.booleans(),
    st.sampled_from(["", " ", "1e6", "2.5e5", "1e400", "nan", "inf", "-0", "1_000", "0x10"]),
    st.sampled_from(["x" * 10_000, "[" * 50, "5 um" * 100, "\x00", "é µm", "{a: 1}"]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**80), max_value=2**80),
    st.lists(st.integers(), max_size=3),
    st.dictionaries(st.sampled_from(["a", "kind", "file"]), st.integers(), max_size=2),
)


def _quantity(dimension: str) -> st.SearchStrategy:
    units = [*DIMENSIONS[dimension], "furlong", "", "mm2"]
    number = st.one_of(
        st.sampled_from(_REALS),
        st.sampled_from(_REALS),
        st.floats(min_value=-1e40, max_value=1e40, allow_nan=False),
        st.sampled_from(["1e-400", "1e400", ".5", "5.", "1e6", "-0"]),
    )
    sensible = st.sampled_from(units[:-3])
    units_drawn = st.one_of(sensible, sensible, sensible, st.sampled_from(units))
    return st.builds(lambda n, u: f"{n} {u}".strip(), number, units_drawn)


def _strip(tp: Any) -> tuple[Any, list]:
    """(base type, metadata) of a possibly Annotated type."""
    if get_origin(tp) is Annotated:
        base, *meta = get_args(tp)
        inner, more = _strip(base)
        return inner, meta + more
    return tp, []


def values(tp: Any, metadata: list | None = None, depth: int = 0) -> st.SearchStrategy:
    """Values of type ``tp`` (as a pydantic field annotation), now and then hostile ones."""
    tp, meta = _strip(tp)
    meta = (metadata or []) + meta
    kind = _quantity_kind(meta)
    if kind is not None:
        dimension = kind.split()[1]
        return st.one_of(*[_quantity(dimension)] * 4, _HOSTILE)
    return st.one_of(*[_typed(tp, depth)] * 5, _HOSTILE)


def _typed(tp: Any, depth: int) -> st.SearchStrategy:
    origin, args = get_origin(tp), get_args(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return model_documents(tp, depth + 1)
    if origin is Literal:
        return st.one_of(st.sampled_from(args), st.sampled_from(NAMES))
    if origin in (Union, types.UnionType):
        return st.one_of(*(values(a, depth=depth) for a in args))
    if origin in (list, tuple):
        items = [a for a in args if a is not Ellipsis] or [Any]
        if origin is tuple and Ellipsis not in args:
            exact = st.tuples(*(values(a, depth=depth + 1) for a in items)).map(list)
            return st.one_of(exact, st.lists(values(items[0], depth=depth + 1), max_size=4))
        return st.lists(values(items[0], depth=depth + 1), max_size=3 if depth < 3 else 1)
    if origin is dict:
        value_type = args[1]
        return st.dictionaries(
            st.sampled_from(NAMES), values(value_type, depth=depth + 1), max_size=2
        )
    if tp is int:
        return st.one_of(st.sampled_from(_NUMBERS), st.integers(-5, 50))
    if tp is float:
        return st.one_of(st.sampled_from(_REALS), st.floats())
    if tp is bool:
        return st.booleans()
    if tp is str:
        return st.one_of(st.sampled_from(NAMES), st.text(max_size=12))
    if tp is Path:
        return st.sampled_from(FILES)
    return _HOSTILE


def model_documents(model: type[BaseModel], depth: int = 0) -> st.SearchStrategy:
    """Mappings for ``model``: required keys mostly present, others sometimes, and now and
    then an unknown key."""
    if depth > 5:
        return st.just({})
    parts = {}
    for name, field in model.model_fields.items():
        value = values(field.annotation, list(field.metadata), depth)
        keep = st.booleans() if not field.is_required() else st.sampled_from([True] * 9 + [False])
        parts[name] = st.tuples(keep, value)

    def assemble(drawn: dict, extra: bool) -> dict:
        doc = {k: v for k, (keep, v) in drawn.items() if keep}
        if extra:
            doc["colour"] = "blue"
        return doc

    return st.builds(assemble, st.fixed_dictionaries(parts), st.sampled_from([False] * 15 + [True]))


def schema_paths(model: type[BaseModel], prefix: tuple = ()) -> list[tuple[tuple, Any, list]]:
    """(path, annotation, metadata) of every field under ``model``, lists at index 0 and dicts
    at key "s" (the names VALID uses), through optional, union and list types."""
    found = []
    for name, field in model.model_fields.items():
        path = (*prefix, name)
        found.append((path, field.annotation, list(field.metadata)))
        for sub, sub_prefix in _models_in(field.annotation, path):
            found += schema_paths(sub, sub_prefix)
    return found


def _models_in(tp: Any, path: tuple) -> list[tuple[type[BaseModel], tuple]]:
    tp, _ = _strip(tp)
    origin, args = get_origin(tp), get_args(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return [(tp, path)]
    if origin in (Union, types.UnionType):
        return [m for a in args for m in _models_in(a, path)]
    if origin in (list, tuple):
        return [m for a in args if a is not Ellipsis for m in _models_in(a, (*path, 0))]
    if origin is dict:
        return [(m, (*path, _entry(m))) for m, _ in _models_in(args[1], ())]
    return []


def _entry(model: type[BaseModel]) -> str:
    """The VALID entry of a mapping that holds ``model``: its ``kind`` if it has one, else s."""
    kind = model.model_fields.get("kind")
    if kind is not None and get_origin(kind.annotation) is Literal:
        return str(get_args(kind.annotation)[0])
    return "s"


PATHS = schema_paths(RunConfig)


def _set(doc: dict, path: tuple, value: object) -> dict:
    """``doc`` with ``value`` at ``path`` (intermediate mappings and lists made as needed)."""
    node: Any = doc
    for key, nxt in itertools.pairwise(path):
        node = _child(node, key, [] if isinstance(nxt, int) else {})
    last = path[-1]
    if isinstance(node, list) and isinstance(last, int):
        while len(node) <= last:
            node.append({})
        node[last] = value
    elif isinstance(node, dict):
        node[last] = value
    return doc


def _child(node: Any, key: object, empty: Any) -> Any:
    """``node[key]`` as a container of ``empty``'s kind (made or replaced if it is not one)."""
    if isinstance(node, list) and isinstance(key, int):
        while len(node) <= key:
            node.append({})
    elif not isinstance(node, dict):
        return empty  # an earlier mutation put a scalar here: the rest goes nowhere
    if not isinstance(node[key] if key in node or isinstance(node, list) else None, type(empty)):
        node[key] = empty
    return node[key]


#: VALID with activeness on the rough face and steps asked for (issue 27's keys), so that
#: mutations reach the activeness checks and the distances to a rough surface.
VALID_ACTIVE = copy.deepcopy(VALID)
VALID_ACTIVE["targets"][0]["activeness"] = [{"fccd": "2 um", "dlf": 0.5, "faces": ["+z"]}]
VALID_ACTIVE["output"] = {"steps": True}


@st.composite
def mutations(draw, base: dict | None = None) -> dict:
    """``base`` (default VALID) with one to three values replaced at schema paths."""
    doc = copy.deepcopy(VALID if base is None else base)
    if isinstance(doc.get("physics"), str):
        doc["physics"] = {"mode": doc["physics"]}
    for _ in range(draw(st.sampled_from([1, 1, 1, 2, 3]))):
        path, tp, meta = draw(st.sampled_from(PATHS))
        doc = _set(doc, path, draw(values(tp, meta)))
    return doc


def documents() -> st.SearchStrategy:
    """Run descriptions: mutated valid ones and whole generated ones."""
    return st.one_of(
        *[mutations()] * 4,
        mutations(VALID_ACTIVE),
        mutations(VALID_ACTIVE),
        model_documents(RunConfig),
    )


# -------------------------------------------------------------------------------- command lines


def commands(group: click.Group, skip: set[str], path: tuple = ()) -> list[tuple]:
    """(command path, click command) of every command under ``group`` not in ``skip``."""
    found = []
    for name, cmd in group.commands.items():
        where = (*path, name)
        if " ".join(where) in skip:
            continue
        if isinstance(cmd, click.Group):
            found += commands(cmd, skip, where)
        else:
            found.append((where, cmd))
    return found


#: Files an argument or option is likely to want, by words of its name (a guess that only makes
#: valid command lines more frequent; any file of FILES is still drawn).
_LIKELY = {
    "config": "c.yaml",
    "description": "s.yaml",
    "results": "r.h5",
    "macro": "m.mac",
    "file": "s.s4s.h5",
    "files": "r.h5",
}


def _param_values(param: click.Parameter) -> st.SearchStrategy:
    t = param.type
    likely = next((f for word, f in _LIKELY.items() if word in (param.name or "")), None)
    if likely is not None and isinstance(t, click.Path):
        return st.one_of(st.just(likely), st.just(likely), st.sampled_from(FILES))
    words = st.sampled_from(["5 MeV", "103 keV", "20 nm", "2 pm", "1e20", "0", "-1", "x" * 300])
    if isinstance(t, click.Choice):
        return st.one_of(st.sampled_from(list(t.choices)), words)
    if isinstance(t, (click.Path, click.File)):
        return st.sampled_from(FILES)
    if isinstance(t, (click.IntRange, click.types.IntParamType)) or t.name == "integer":
        return st.one_of(st.sampled_from(["1", "5", "1e3", "1e20", "0", "-3", "2.5"]), words)
    return st.one_of(words, st.sampled_from(NAMES + FILES), st.text(max_size=8))


@st.composite
def command_line(draw, available: list[tuple]) -> list[str]:
    """One command line for a command of ``available`` (see :func:`commands`)."""
    where, cmd = draw(st.sampled_from(available))
    argv = list(where)
    for param in cmd.params:
        if isinstance(param, click.Argument):
            n = draw(st.integers(1, 2)) if param.nargs == -1 else param.nargs
            argv += [draw(_param_values(param)) for _ in range(n)]
            continue
        if not draw(st.booleans()):
            continue
        flag = param.opts[-1] if param.opts[-1].startswith("--") else param.opts[0]
        if getattr(param, "is_flag", False):
            argv.append(flag)
        else:
            argv += [flag, draw(_param_values(param))]
    if draw(st.sampled_from([False] * 9 + [True])):  # an unknown option now and then
        argv.append("--colour")
    return argv
