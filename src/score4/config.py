"""Run configuration: YAML validated into typed objects.

Every quantity with a dimension is written with its unit ("5.3 MeV", "3 cm") and stored in
Geant4 internal units (mm, MeV). Unknown keys are errors, so a typo never silently falls
back to a default. :func:`load_config` turns any problem into one :class:`ConfigError` line
that names the file, the key path, the value and the rule.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator, model_validator

from .errors import ConfigError
from .units import parse_quantity


def _quantity(dimension: str):
    return BeforeValidator(lambda v: parse_quantity(v, dimension))


Length = Annotated[float, _quantity("length")]
Energy = Annotated[float, _quantity("energy")]
PositiveLength = Annotated[float, _quantity("length"), Field(gt=0)]
PositiveEnergy = Annotated[float, _quantity("energy"), Field(gt=0)]
Vector3 = tuple[Length, Length, Length]
Size3 = tuple[PositiveLength, PositiveLength, PositiveLength]

FACES = ("+x", "-x", "+y", "-y", "+z", "-z")


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BoxVolume(_Model):
    """A box-shaped volume: full edge lengths, centre position in the world."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")
    material: str = "G4_Si"
    size: Size3
    position: Vector3 = (0.0, 0.0, 0.0)


class WorldConfig(_Model):
    material: str = "G4_Galactic"
    margin: PositiveLength = 10.0  # space around the targets, mm


class FaceRef(_Model):
    """A face of a box volume, e.g. the top face ``+z`` of volume ``crystal``."""

    volume: str
    face: Literal["+x", "-x", "+y", "-y", "+z", "-z"] = "+z"


class SourceConfig(_Model):
    """Particles started uniformly on a face (issue 2: flat faces, depth 0)."""

    particle: str = "alpha"
    energy: PositiveEnergy
    # isotropic (4 pi), inward/outward (isotropic in that half-space), normal (a beam along the inward normal)
    direction: Literal["isotropic", "inward", "outward", "normal"] = "isotropic"
    surface: FaceRef


class PhysicsConfig(_Model):
    mode: Literal["auto", "full", "lite"] = "auto"
    # Secondary-production threshold as a range. Geant4's default (0.7 mm) suppresses delta rays
    # and, with them, all range straggling of alphas; micrometre surfaces need a micrometre cut.
    production_cut: PositiveLength = 1e-3


class RunSettings(_Model):
    events: int = Field(1000, gt=0)
    seed: int = Field(1, ge=0, lt=2**63)
    chunk_events: int = Field(10_000, gt=0)


class HistogramConfig(_Model):
    bins: int = Field(100, gt=0)
    max: PositiveEnergy | None = None  # default: the largest primary energy of the run


class OutputConfig(_Model):
    histogram: HistogramConfig = HistogramConfig()
    track_length: bool = False  # also score the summed charged/neutral track length per volume (mm)


class RunConfig(_Model):
    """A complete run description."""

    physics: PhysicsConfig = PhysicsConfig()
    world: WorldConfig = WorldConfig()
    targets: list[BoxVolume] = Field(min_length=1)
    source: SourceConfig
    run: RunSettings = RunSettings()
    output: OutputConfig = OutputConfig()

    @field_validator("physics", mode="before")
    @classmethod
    def _physics_shorthand(cls, v):
        return {"mode": v} if isinstance(v, str) else v

    @model_validator(mode="after")
    def _check_references(self) -> "RunConfig":
        names = [t.name for t in self.targets]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"targets: volume names must be unique, repeated: {', '.join(dupes)}")
        if self.source.surface.volume not in names:
            raise ValueError(
                f"source.surface.volume: {self.source.surface.volume!r} is not a target; targets are: {', '.join(names)}"
            )
        return self

    def target(self, name: str) -> BoxVolume:
        return next(t for t in self.targets if t.name == name)


def _format_validation_error(err: ValidationError, origin: str) -> str:
    first = err.errors()[0]
    loc = ".".join(str(p) for p in first["loc"])
    msg = first["msg"].removeprefix("Value error, ")
    if first["type"] == "extra_forbidden":
        msg = "unknown key (check the spelling; see the config reference)"
    value = first.get("input")
    shown = "" if first["type"] in ("missing",) or isinstance(value, dict) else f" (got {value!r})"
    more = f" [+{len(err.errors()) - 1} more problem(s)]" if len(err.errors()) > 1 else ""
    where = f"{origin}: {loc}: " if loc else f"{origin}: "
    return f"{where}{msg}{shown}{more}"


def parse_config(data: object, origin: str = "config") -> RunConfig:
    """Validate a mapping (parsed YAML) into a :class:`RunConfig`."""
    if not isinstance(data, dict):
        raise ConfigError(f"{origin}: the top level must be a mapping of keys, got {type(data).__name__}")
    try:
        return RunConfig.model_validate(data)
    except ValidationError as err:
        raise ConfigError(_format_validation_error(err, origin)) from None


def load_config(path: str | Path) -> RunConfig:
    """Read and validate a YAML run configuration file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"config: file {str(path)!r} does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        where = getattr(err, "problem_mark", None)
        line = f" line {where.line + 1}" if where is not None else ""
        raise ConfigError(f"config: {path}{line}: not valid YAML ({getattr(err, 'problem', err)})") from None
    return parse_config(data, origin=str(path))


def config_to_dict(config: RunConfig) -> dict:
    """Plain data (internal units) for storage with the results."""
    return config.model_dump(mode="json")
