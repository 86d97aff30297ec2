"""Detector response: quenching per particle class, energy resolution and threshold.

A detector does not see the deposited energy ``E`` itself. score4's response model, applied per
event and per detector to the deposits of a results file (:func:`visible_energy`,
:func:`apply_response`):

1. **Quenching** (light or ionisation channels): the visible energy is
   ``E_vis = q_alpha E_alpha + q_ion E_ion + q_electron E_electron``, where ``E_class`` is the
   energy deposited by steps of particles of that class (``output.split_by_particle``:
   alpha; electron = e-, e+, gamma; ion = the rest, i.e. nuclear recoils). Delta electrons
   knocked out by an alpha above the production cut count as electrons (see docs/templates.md).
2. **Resolution**: ``E_vis`` is smeared once per event with a Gaussian of standard deviation
   ``sigma(E_vis)``: ``sigma(E)^2 = a^2 + b E + (c E)^2`` (``a``: noise, an energy; ``b``: the
   Fano-like term, an energy, e.g. F w = 0.11 x 2.96 eV for germanium; ``c``: the constant
   relative term, a number), or linear interpolation in a table of ``E sigma`` rows. Each detector
   has its own random stream (``numpy.random.default_rng([seed, crc32(name)])``): the same seed
   gives the same smeared events, whichever other detectors are chosen.
3. **Threshold**: a detector sees an event when its smeared energy is above ``threshold``.

The response is given as ``response:`` in the run configuration, or as a YAML file holding the
same keys (``score4 template --response FILE``).
"""

from __future__ import annotations

import re
import zlib
from pathlib import Path
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, ValidationError, model_validator

from score4.errors import ConfigError
from score4.inputs.schema import (
    ConfigPath,
    NonNegativeEnergy,
    StrictModel,
    describe_validation_error,
)
from score4.inputs.units import ENERGY
from score4.inputs.yamlfile import load_yaml

#: Particle classes of the split deposits and their results-file quantities.
CLASSES = {"alpha": "edep_alpha", "ion": "edep_ion", "electron": "edep_electron"}
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


_UNIT_LINE = re.compile(r"^#\s*unit\s*:\s*(\S+)\s*$")


def _sigma_table(cfg: ResolutionConfig) -> tuple[np.ndarray, np.ndarray]:
    """(energies, sigmas) in MeV from a resolution table file."""
    from score4.source.sampling import read_table

    assert cfg.file is not None  # the model requires it for kind table
    energy, sigma = read_table(
        cfg.file, "energy", cfg.unit, what="resolution table", xname="energy"
    )
    unit = cfg.unit
    for line in Path(cfg.file).read_text().splitlines():
        if match := _UNIT_LINE.match(line.strip()):
            unit = match.group(1)
    assert unit is not None  # read_table requires a unit
    return energy, np.asarray(sigma, float) * ENERGY[unit]


def sigma_function(cfg: ResolutionConfig):
    """sigma(E) (MeV -> MeV, vectorised) of a resolution section."""
    if cfg.kind == "table":
        energy, sigma = _sigma_table(cfg)
        return lambda e: np.interp(e, energy, sigma)
    a, b, c = cfg.a or 0.0, cfg.b or 0.0, cfg.c or 0.0
    return lambda e: np.sqrt(a * a + b * np.maximum(e, 0.0) + (c * e) ** 2)


def needs_split(response: ResponseConfig) -> bool:
    """True when the quenching needs deposits split by particle class."""
    return not response.quenching.trivial


def visible_energy(scores: dict[str, dict[str, np.ndarray]], volume: str, response: ResponseConfig):
    """Quenched energy (MeV) per event in ``volume`` (deposits if there is no quenching)."""
    q = response.quenching
    if q.trivial:  # the active energy when the run has activeness
        return np.asarray(scores.get("active_edep", scores["edep"])[volume], float)
    if "active_edep" in scores:
        raise ConfigError(
            "response.quenching: quenching factors with activeness are not supported yet (the "
            "active energy is not split by particle class); use quenching 1 or a run without "
            "targets[].activeness"
        )
    missing = [quantity for quantity in CLASSES.values() if quantity not in scores]
    if missing:
        raise ConfigError(
            "response.quenching: quenching factors need the deposits split by particle class, "
            "which this results file lacks; run again with output: {split_by_particle: true}"
        )
    return sum(getattr(q, name) * scores[quantity][volume] for name, quantity in CLASSES.items())


def apply_response(
    scores: dict[str, dict[str, np.ndarray]], volumes: list[str], response: ResponseConfig
) -> dict[str, np.ndarray]:
    """{volume: measured energy per event (MeV)}: quenched, smeared; events the detector does not
    see (nothing deposited, or at or below the threshold) are exactly 0."""
    sigma = sigma_function(response.resolution) if response.resolution is not None else None
    out = {}
    for volume in volumes:
        e = visible_energy(scores, volume, response)
        hit = e > 0
        if sigma is not None:
            # one stream per detector name: its smearing does not depend on the other detectors
            rng = np.random.default_rng([response.seed, zlib.crc32(volume.encode())])
            noise = rng.standard_normal(len(e))  # one draw per event, seen or not
            e = np.where(hit, e + sigma(e) * noise, 0.0)
        out[volume] = np.where(hit & (e > response.threshold), e, 0.0)
    return out


def response_to_dict(response: ResponseConfig) -> dict:
    """Plain data (energies with units) for storage with a template."""
    return response.model_dump(mode="json")
