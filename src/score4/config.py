"""Run configuration: YAML validated into typed objects.

Every quantity with a dimension is written with its unit ("5.3 MeV", "3 cm") and stored in
Geant4 internal units (mm, MeV). Unknown keys are errors, so a typo never silently falls
back to a default. :func:`load_config` turns any problem into one :class:`ConfigError` line
that names the file, the key path, the value and the rule.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import yaml
from pydantic import Field, ValidationError, field_validator, model_validator

from .errors import ConfigError
from .schema import PositiveEnergy, PositiveLength, Size3, StrictModel, Vector3, describe_validation_error

FACES = ("+x", "-x", "+y", "-y", "+z", "-z")


class BoxVolume(StrictModel):
    """A box-shaped volume: full edge lengths, centre position in the world."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")
    material: str = "G4_Si"
    size: Size3
    position: Vector3 = (0.0, 0.0, 0.0)


class WorldConfig(StrictModel):
    material: str = "G4_Galactic"
    margin: PositiveLength = 10.0  # space around the targets, mm


class FaceRef(StrictModel):
    """A face of a box volume, e.g. the top face ``+z`` of volume ``crystal``."""

    volume: str
    face: Literal["+x", "-x", "+y", "-y", "+z", "-z"] = "+z"


class SourceConfig(StrictModel):
    """Particles started uniformly on a face (issue 2: flat faces, depth 0)."""

    particle: str = "alpha"
    energy: PositiveEnergy
    # isotropic (4 pi), inward/outward (isotropic in that half-space), normal (a beam along the inward normal)
    direction: Literal["isotropic", "inward", "outward", "normal"] = "isotropic"
    surface: FaceRef


class PhysicsConfig(StrictModel):
    mode: Literal["auto", "full", "lite"] = "auto"
    # Secondary-production threshold as a range. Geant4's default (0.7 mm) suppresses delta rays
    # and, with them, all range straggling of alphas; micrometre surfaces need a micrometre cut.
    production_cut: PositiveLength = 1e-3


class RunSettings(StrictModel):
    events: int = Field(1000, gt=0)
    seed: int = Field(1, ge=0, lt=2**63)
    chunk_events: int = Field(10_000, gt=0)


class HistogramConfig(StrictModel):
    bins: int = Field(100, gt=0)
    max: PositiveEnergy | None = None  # default: the largest primary energy of the run


class OutputConfig(StrictModel):
    histogram: HistogramConfig = HistogramConfig()
    track_length: bool = False  # also score the summed charged/neutral track length per volume (mm)


class RunConfig(StrictModel):
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


def parse_config(data: object, origin: str = "config") -> RunConfig:
    """Validate a mapping (parsed YAML) into a :class:`RunConfig`."""
    if not isinstance(data, dict):
        raise ConfigError(f"{origin}: the top level must be a mapping of keys, got {type(data).__name__}")
    try:
        return RunConfig.model_validate(data)
    except ValidationError as err:
        raise ConfigError(describe_validation_error(err, origin)) from None


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
