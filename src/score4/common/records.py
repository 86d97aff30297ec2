"""Read-only copies of validated configuration models, for processes that only read them.

A worker reads a few values of the run's configuration (``physics.production_cut``, a rough
entry's ``into``, a material entry's ``density``) but never validates one. The parent sends it
each pydantic model of the plan as a :class:`Record`: the model's fields and the values of its
properties, as attributes, under the model's class name. Unpickling a record needs this module
only, so a worker never imports pydantic or the configuration's models
(:func:`score4.runner.run_plan.worker_pickle` makes them).
"""

from __future__ import annotations

from typing import Any


class Record:
    """The fields and property values of one validated model, read-only.

    ``record.kind`` is the model's class name (``"BoxVolume"``); :func:`kind_of` reads it from a
    record or a model alike.
    """

    __slots__ = ("_kind", "_values")

    def __init__(self, kind: str, values: dict[str, Any]) -> None:
        object.__setattr__(self, "_kind", kind)
        object.__setattr__(self, "_values", dict(values))

    @property
    def kind(self) -> str:
        return self._kind

    def __getattr__(self, name: str) -> Any:
        try:
            return self._values[name]
        except KeyError:
            raise AttributeError(f"{self._kind} record has no attribute {name!r}") from None

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{self._kind} record is read-only")

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        return Record, (self._kind, self._values)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Record):
            return NotImplemented
        return (self._kind, self._values) == (other._kind, other._values)

    __hash__ = None  # type: ignore[assignment]  # as mutable-looking as a dict of values

    def __repr__(self) -> str:
        fields = ", ".join(f"{k}={v!r}" for k, v in self._values.items())
        return f"{self._kind}({fields})"


def kind_of(obj: object) -> str:
    """The class name of a model, or of the model a :class:`Record` copies."""
    return obj.kind if isinstance(obj, Record) else type(obj).__name__
