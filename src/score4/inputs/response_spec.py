"""The ``response:`` section of a run configuration, and response files (the same keys): the
validated models. What the response does to deposits is :mod:`score4.analysis.response`."""

from __future__ import annotations

from pathlib import Path
from typing import ClassVar, Literal

from pydantic import Field, ValidationError, model_validator

from score4.common.schema import (
    ConfigPath,
    NonNegativeEnergy,
    StrictModel,
    describe_validation_error,
)
from score4.common.yamlfile import load_yaml
from score4.errors import ConfigError

#: A quenching factor above this is a slip (the largest measured ratios are ~1.1, for alphas in
#: some bolometers' heat channel).
MAX_QUENCHING = 2.0


class ResolutionConfig(StrictModel):
    """sigma(E): ``kind: formula`` (``a``, ``b``, ``c``) or ``kind: table`` (``file``)."""

    used_only_with: ClassVar[dict[str, tuple[str, tuple[object, ...]]]] = {
        "a": ("kind", ("formula",)),
        "b": ("kind", ("formula",)),
        "c": ("kind", ("formula",)),
        "file": ("kind", ("table",)),
        "unit": ("kind", ("table",)),
    }

    kind: Literal["formula", "table"] = "formula"
    a: NonNegativeEnergy | None = None  # noise term: sigma at E = 0
    b: NonNegativeEnergy | None = None  # Fano-like term: sigma^2 grows by b per unit of E
    c: float | None = Field(None, ge=0, lt=1)  # constant relative term: sigma/E at high E
    file: ConfigPath | None = None  # rows "energy sigma", both in the table's unit
    unit: str | None = None  # the table's unit unless the file has "# unit: keV"

    @model_validator(mode="after")
    def _complete(self) -> ResolutionConfig:
        if self.kind == "table" and self.file is None:
            raise ValueError("kind table needs file (rows 'energy sigma')")
        if self.kind == "formula" and not any(v for v in (self.a, self.b, self.c)):
            raise ValueError("kind formula needs at least one of a, b, c greater than 0")
        return self


class QuenchingConfig(StrictModel):
    """Visible energy per deposited energy, per particle class (1 = no quenching)."""

    alpha: float = Field(1.0, gt=0, le=MAX_QUENCHING)
    ion: float = Field(1.0, gt=0, le=MAX_QUENCHING)
    electron: float = Field(1.0, gt=0, le=MAX_QUENCHING)

    @property
    def trivial(self) -> bool:
        return self.alpha == self.ion == self.electron == 1.0


class ResponseConfig(StrictModel):
    """The ``response:`` section (or a response file): see the module notes."""

    channel: str = Field("energy", min_length=1)  # a label: heat, light, ionisation, ...
    quenching: QuenchingConfig = Field(default_factory=QuenchingConfig)
    resolution: ResolutionConfig | None = None
    threshold: NonNegativeEnergy = 0.0
    seed: int = Field(0, ge=0, lt=2**63)


def load_response(path: str | Path) -> ResponseConfig:
    """Read and validate a response file (the keys of ``response:``)."""
    path = Path(path)
    data = load_yaml(path, "response")
    if not isinstance(data, dict):
        raise ConfigError(
            f"{path}: a response file is a mapping of keys (quenching, resolution, ...)"
        )
    try:
        return ResponseConfig.model_validate(data, context={"base_dir": path.parent})
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, str(path))) from None
