"""Import the original SCoRe4's Geant4 macros as score4 run configurations.

:func:`import_macro` reads a plain Geant4 macro (no ``/control/alias``) written for the
original C++ SCoRe4 and returns a score4 run configuration (a mapping that
:func:`score4.config.parse_config` accepts) together with an :class:`ImportReport` that accounts
for every command: converted (line -> config key), ignored on purpose (with the reason), or
not converted (unknown commands and values score4 cannot represent; never dropped silently).
:func:`write_config` writes the configuration as commented YAML.

The half-length rule
--------------------
The original's setters take Geant4 *half*-lengths (G4Box/G4Trd convention): spike half-widths,
basis and portal half-sizes. score4 uses full lengths everywhere, so each of them is doubled.
Heights follow the original's geometry exactly (notes §1.1 ``Spike``): a pyramid is one G4Trd
of half-height ``MeanHeight`` centred at z = ``MeanHeight``, so its full height is
**2 x setSpikeMeanHeight** (and the Gaussian sigma of UniformPyramid doubles with it); Bump
and Peak stack layers whose heights add up to ``MeanHeight``, so their full height is
**1 x setSpikeMeanHeight**.

What the macro cannot say (the original builds it in C++) is filled with stated defaults: a
target block of the patch material under the rough face, 1 mm thick, with the face at z = 0;
the face ``+z``; the source on that face. Each default is listed in the report and in the
YAML header.
"""

from __future__ import annotations

import datetime as dt
import math
import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .config import parse_config
from .errors import ConfigError
from .units import ENERGY as SCORE4_ENERGY
from .units import LENGTH as SCORE4_LENGTH
from .units import parse_quantity

__all__ = ["ImportReport", "ReportItem", "import_macro", "render_yaml", "write_config"]

# --------------------------------------------------------------------------------------------
# Geant4 units (G4UnitDefinition names and symbols), factor to score4's internal unit
# --------------------------------------------------------------------------------------------

_G4_LENGTH = {  # symbol -> mm; names map to symbols below
    "pc": 3.0856775807e19,
    "km": 1e6,
    "m": 1e3,
    "cm": 10.0,
    "mm": 1.0,
    "um": 1e-3,
    "nm": 1e-6,
    "Ang": 1e-7,
    "fm": 1e-12,
}
_G4_LENGTH_NAMES = {
    "parsec": "pc",
    "kilometer": "km",
    "meter": "m",
    "centimeter": "cm",
    "millimeter": "mm",
    "micrometer": "um",
    "nanometer": "nm",
    "angstrom": "Ang",
    "fermi": "fm",
}
_G4_ENERGY = {  # symbol -> MeV
    "meV": 1e-9,
    "eV": 1e-6,
    "keV": 1e-3,
    "MeV": 1.0,
    "GeV": 1e3,
    "TeV": 1e6,
    "PeV": 1e9,
    "J": 6.241509074e12,
}
_G4_ENERGY_NAMES = {
    "millielectronVolt": "meV",
    "electronvolt": "eV",
    "kiloelectronvolt": "keV",
    "megaelectronvolt": "MeV",
    "gigaelectronvolt": "GeV",
    "teraelectronvolt": "TeV",
    "petaelectronvolt": "PeV",
    "joule": "J",
}
_UNITS = {
    "length": (_G4_LENGTH, _G4_LENGTH_NAMES, SCORE4_LENGTH, "mm"),
    "energy": (_G4_ENERGY, _G4_ENERGY_NAMES, SCORE4_ENERGY, "MeV"),
}

_NUMBER = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
_INTEGER = re.compile(r"^[+-]?\d+$")

#: Name given to a helper written in the paper's short form ``/Surface/RoughnessHelper/<cmd>``
#: (Listing 4 of the paper omits the helper name that the real library puts in the path).
UNNAMED_HELPER = "rough"
#: Name, thickness and material of the target block filled in under the rough face.
DEFAULT_TARGET = "target"
DEFAULT_TARGET_THICKNESS = "1 mm"
DEFAULT_MATERIAL = "G4_Si"
#: Relative tolerance of the size rules (the original compares to an absolute 2e-15 mm).
_RTOL = 1e-9


@dataclass(frozen=True)
class _Quantity:
    """A value read from the macro: number and Geant4 unit symbol as written, and internal value."""

    number: float
    unit: str
    value: float  # mm or MeV
    dimension: str

    def text(self, factor: float = 1.0) -> str:
        """``"<factor x number> <unit>"`` in a unit score4 reads (the macro's own when possible)."""
        _, _, score4_units, internal = _UNITS[self.dimension]
        if self.unit in score4_units:
            return f"{_g(self.number * factor)} {self.unit}"
        return f"{_g(self.value * factor)} {internal}"


def _g(x: float) -> str:
    return f"{x:.12g}"


# --------------------------------------------------------------------------------------------
# Reading the macro
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Command:
    file: Path
    line: int
    path: str
    args: tuple[str, ...]
    order: int  # position in execution order (included macros expand in place)

    @property
    def where(self) -> str:
        return f"{self.file} line {self.line}"

    @property
    def text(self) -> str:
        return " ".join((self.path, *self.args))

    def fail(self, message: str) -> ConfigError:
        return ConfigError(f"{self.where}: {self.path}: {message}")


def _tokens(line: str) -> list[str]:
    """Split on blanks; double quotes group (Geant4's G4UIbatch tokenizer)."""
    out: list[str] = []
    cur: list[str] = []
    quoted = started = False
    for ch in line:
        if ch == '"':
            quoted, started = not quoted, True
        elif ch.isspace() and not quoted:
            if started:
                out.append("".join(cur))
            cur, started = [], False
        else:
            cur.append(ch)
            started = True
    if started:
        out.append("".join(cur))
    return out


def _read(path: Path, commands: list[_Command], stack: tuple[Path, ...]) -> None:
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"FILE.mac: cannot read {str(path)!r} ({err})") from None
    pending: list[str] = []
    first = 0
    for number, raw in enumerate(text.splitlines(), start=1):
        tokens = _tokens(raw)
        if not pending:
            first = number
        continued = False
        for tok in tokens:
            if tok.startswith("#"):  # a token starting with '#' ends the command (G4UIbatch)
                break
            if tok in ("_", "\\"):  # continuation mark
                continued = True
                break
            pending.append(tok)
        if continued or not pending:
            continue
        cmd_path = pending[0] if pending[0].startswith("/") else "/" + pending[0]
        cmd = _Command(path, first, cmd_path, tuple(pending[1:]), len(commands))
        pending = []
        if cmd.path == "/control/execute":
            _include(cmd, commands, stack)
        else:
            commands.append(cmd)
    if pending:
        raise ConfigError(
            f"{path} line {first}: the last command ends with a continuation mark '_'"
        )


def _include(cmd: _Command, commands: list[_Command], stack: tuple[Path, ...]) -> None:
    """Expand ``/control/execute FILE`` in place (FILE looked for beside the macro, then here)."""
    if len(cmd.args) != 1:
        raise cmd.fail(f"expected one macro file name, got {' '.join(cmd.args)!r}")
    name = Path(cmd.args[0])
    candidates = [name] if name.is_absolute() else [cmd.file.parent / name, Path.cwd() / name]
    found = next((c for c in candidates if c.is_file()), None)
    if found is None:
        raise cmd.fail(
            f"macro {cmd.args[0]!r} not found (looked in "
            f"{', '.join(str(c.parent) for c in candidates)})"
        )
    if found.resolve() in {p.resolve() for p in stack}:
        raise cmd.fail(f"macro {cmd.args[0]!r} executes itself (a loop)")
    commands.append(cmd)  # reported as converted: its commands follow
    _read(found, commands, (*stack, found))


# --------------------------------------------------------------------------------------------
# Values
# --------------------------------------------------------------------------------------------


def _quantity(
    cmd: _Command,
    dimension: str,
    default_unit: str | None = None,
    index: int = 0,
    minimum: str = "positive",
) -> _Quantity:
    """``<number> [unit]`` at ``args[index:]``; a unit is needed unless there is a default."""
    symbols, names, _, _ = _UNITS[dimension]
    accepted = ", ".join(symbols)
    a = "an" if dimension[0] in "aeiou" else "a"
    args = cmd.args[index:]
    shown = " ".join(args)
    if not args or len(args) > 2:
        raise cmd.fail(
            f"{shown!r} is not {a} {dimension}; write '<number> <unit>' (unit one of: {accepted})"
        )
    if not _NUMBER.match(args[0]):
        raise cmd.fail(
            f"{shown!r} is not {a} {dimension}; write '<number> <unit>' (unit one of: {accepted})"
        )
    unit = args[1] if len(args) == 2 else default_unit
    if unit is None:
        raise cmd.fail(f"{shown!r} has no unit; this command needs one of: {accepted}")
    unit = names.get(unit, unit)
    if unit not in symbols:
        other = "energy" if dimension == "length" else "length"
        kind = (
            f"an {other} unit"
            if unit in _UNITS[other][0] or unit in _UNITS[other][1]
            else "not a Geant4 unit"
        )
        raise cmd.fail(
            f"{shown!r} is not {a} {dimension}: {unit!r} is {kind} (use one of: {accepted})"
        )
    number = float(args[0])
    value = number * symbols[unit]
    if not math.isfinite(value) or (minimum == "positive" and value <= 0) or value < 0:
        rule = "> 0" if minimum == "positive" else ">= 0"
        raise cmd.fail(f"{shown!r}: the {dimension} must be {rule}")
    return _Quantity(number, unit, value, dimension)


def _count(cmd: _Command, minimum: int = 1, index: int = 0) -> int:
    value = cmd.args[index] if len(cmd.args) > index else ""
    if len(cmd.args) != index + 1 or not _INTEGER.match(value) or int(value) < minimum:
        raise cmd.fail(f"{' '.join(cmd.args[index:])!r} is not an integer >= {minimum}")
    return int(value)


def _word(cmd: _Command, choices: tuple[str, ...] | None = None) -> str:
    if len(cmd.args) != 1:
        raise cmd.fail(f"expected one word, got {' '.join(cmd.args)!r}")
    value = cmd.args[0]
    if choices is not None and value not in choices:
        raise cmd.fail(
            f"{value!r} is not one of {', '.join(choices)} (the original exits on any other value)"
        )
    return value


# --------------------------------------------------------------------------------------------
# The report
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ReportItem:
    """One macro command and what became of it: the config key(s) or the reason."""

    where: str  # "line 12" (or "other.mac line 3" for an executed macro)
    command: str
    detail: str
    order: int = 0

    def __str__(self) -> str:
        return f"{self.where}: {self.command} -> {self.detail}"


@dataclass
class ImportReport:
    """What :func:`import_macro` did with each command of a macro.

    ``unknown`` holds commands that were not converted: unknown commands and values score4 cannot
    represent. ``defaults`` holds ``(key, value and why)`` for what score4 needs and the macro
    does not say. ``files`` maps file names (beside the output config) to the text to write there.
    """

    macro: Path
    converted: list[ReportItem] = field(default_factory=list)
    ignored: list[ReportItem] = field(default_factory=list)
    unknown: list[ReportItem] = field(default_factory=list)
    defaults: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)

    def lines(self) -> list[str]:
        """The report as text lines (the YAML header uses the same lines)."""
        out = ["Converted:"]
        out += [f"  {item}" for item in sorted(self.converted, key=lambda i: i.order)] or [
            "  (nothing)"
        ]
        out.append("Defaults filled in (not in the macro):")
        out += [f"  {key} = {why}" for key, why in self.defaults] or ["  (none)"]
        out.append("Ignored on purpose:")
        out += [f"  {item}" for item in sorted(self.ignored, key=lambda i: i.order)] or ["  (none)"]
        out.append("NOT converted (unknown commands or values score4 cannot represent):")
        out += [f"  {item}" for item in sorted(self.unknown, key=lambda i: i.order)] or ["  (none)"]
        if self.notes:
            out.append("Notes:")
            out += [f"  - {note}" for note in self.notes]
        return out


# --------------------------------------------------------------------------------------------
# Command tables
# --------------------------------------------------------------------------------------------

_VERBOSE = "output verbosity only"
_VOXEL = (
    "voxel boundary cap of the original's patched G4Voxelizer; score4 builds its solids "
    "without it (DESIGN.md: solids of <= 1e5 spikes, large faces tiled)"
)
_STEP = (
    "G4UserLimits max step on the patch; score4 sets no per-volume step limit (its physics sets "
    "step functions and physics.production_cut)"
)

# param, value kind; kinds: length (> 0), length0 (>= 0), count, word, spikeform
_ROUGHNESS = {
    "setBasisDx": ("basis_dx", "length"),
    "setBasisDy": ("basis_dy", "length"),
    "setBasisDz": ("basis_dz", "length"),
    "setSpikeDx": ("dx", "length"),
    "setSpikeDy": ("dy", "length"),
    "setSpikeMeanHeight": ("mean", "length"),
    "setSpikeDevHeight": ("dev", "length0"),
    "setSpikeform": ("form", "spikeform"),
    "setNLayer": ("nlayer", "count"),
    "setSpikesNx": ("nx", "count"),
    "setSpikesNy": ("ny", "count"),
    "setMaterial": ("material", "word"),
}
_ROUGHNESS_IGNORED = {
    "setVerbose": _VERBOSE,
    "setBoundaryNx": _VOXEL,
    "setBoundaryNy": _VOXEL,
    "setBoundaryNz": _VOXEL,
    "setStepLimit": _STEP,
}
_PORTAL = {
    "setDxPortal": ("dx", "length"),
    "setDyPortal": ("dy", "length"),
    "setDzPortal": ("dz", "length"),
    "setDxSubworld": ("sub_dx", "length"),
    "setDySubworld": ("sub_dy", "length"),
    "setDzSubworld": ("sub_dz", "length"),
    "setNxSubworld": ("nx", "count"),
    "setNySubworld": ("ny", "count"),
    "setMaterial": ("material", "word"),
}
_PORTAL_IGNORED = {"setVerbose": _VERBOSE}
_DESCRIBER = {
    "setSpikeWidth_X": ("dx", "length"),
    "setSpikeWidth_Y": ("dy", "length"),
    "setNrSpike_X": ("nx", "count"),
    "setNrSpike_Y": ("ny", "count"),
    "setMeanHeight": ("mean", "length"),
    "setHeightDeviation": ("dev", "length0"),
    "setSpikeform": ("form", "describer_form"),
    "setNLayer": ("nlayer", "count"),
}
# DescriberParameters defaults (notes §1.1 and §1.8); lengths are half-lengths in mm.
_DESCRIBER_DEFAULTS = {
    "dx": "0.005 mm",
    "dy": "0.005 mm",
    "nx": 1,
    "ny": 1,
    "mean": "0.005 mm",
    "dev": "1 mm",
    "form": "StandardPyramid",
    "nlayer": 1,
}
_DEFAULT_DESCRIBER_WIDTH = _Quantity(0.005, "mm", 0.005, "length")
_SPIKEFORMS = {
    "StandardPyramid": "pyramid",
    "UniformPyramid": "pyramid",
    "Bump": "bump",
    "Peak": "peak",
}

_IGNORED_EXACT = {
    "/run/initialize": "score4 initialises Geant4 itself",
    "/run/printProgress": "progress output only (score4 run shows a progress bar)",
    "/run/numberOfThreads": "score4 runs events in processes: score4 run --jobs N",
    "/run/useMaximumLogicalCores": "score4 runs events in processes: score4 run --jobs N",
    "/control/saveHistory": "Geant4 session history only",
    "/control/echo": "prints text only",
    "/control/stopSavingHistory": "Geant4 session history only",
    "/tracking/storeTrajectory": "trajectories are kept for visualisation only",
    "/SurfaceSource/ShowSurface": "draws the facets (visualisation)",
    "/shift/printShiftTable": "prints the table only",
    "/gps/List": "prints the particle table only",
    "/random/setSavingFlag": "saves the engine status only",
}
_IGNORED_PREFIX = {
    "/vis/": "visualisation",
    "/analysis/": "histogram/ntuple files of the original example; score4 writes its own results "
    "file",
    "/control/cout/": "output redirection only",
    "/gps/pos/": "the original's sampler overwrites the GPS position with a point on the rough "
    "surface; score4 samples on the rough face itself",
    "/gps/ang/rot": "only turns the frame of the angular distribution; the converted one (iso) has "
    "no frame",
}
_GPS_POSITION = {
    "/gps/position",
    "/gps/centre",
    "/gps/type",
    "/gps/shape",
    "/gps/halfx",
    "/gps/halfy",
    "/gps/halfz",
    "/gps/radius",
    "/gps/radius0",
    "/gps/posrot1",
    "/gps/posrot2",
    "/gps/confine",
}


# --------------------------------------------------------------------------------------------
# Collecting the commands
# --------------------------------------------------------------------------------------------


@dataclass
class _Helper:
    """The commands given to one helper (last value wins), in macro order."""

    name: str
    commands: list[tuple[str, Any, _Command]] = field(default_factory=list)

    def set(self, param: str, value: Any, cmd: _Command) -> None:
        self.commands.append((param, value, cmd))

    @property
    def values(self) -> dict[str, tuple[Any, _Command]]:
        return {p: (v, c) for p, v, c in self.commands}

    def get(self, param: str, default: Any = None) -> Any:
        v = self.values.get(param)
        return default if v is None else v[0]

    def set_cmd(self, param: str) -> _Command:
        """The command that set ``param``; only for parameters :meth:`get` found."""
        c = self.cmd(param)
        if c is None:
            raise KeyError(f"{self.name}: {param} was never set")
        return c

    def cmd(self, param: str) -> _Command | None:
        v = self.values.get(param)
        return None if v is None else v[1]


@dataclass
class _State:
    macro: Path
    report: ImportReport
    rough: dict[str, _Helper] = field(default_factory=dict)
    portals: dict[str, _Helper] = field(default_factory=dict)
    describer: _Helper = field(default_factory=lambda: _Helper("surface"))
    settings: dict[str, tuple[Any, _Command]] = field(
        default_factory=dict
    )  # source/run/physics values
    tables: list[tuple[Path, _Command]] = field(default_factory=list)
    beam_on: list[tuple[int, _Command]] = field(default_factory=list)
    initialized: _Command | None = None

    def where(self, cmd: _Command) -> str:
        return f"line {cmd.line}" if cmd.file == self.macro else f"{cmd.file.name} line {cmd.line}"

    def item(self, cmd: _Command, detail: str) -> ReportItem:
        return ReportItem(self.where(cmd), cmd.text, detail, cmd.order)

    def converted(self, cmd: _Command, detail: str) -> None:
        self.report.converted.append(self.item(cmd, detail))

    def ignored(self, cmd: _Command, reason: str) -> None:
        self.report.ignored.append(self.item(cmd, reason))

    def unknown(self, cmd: _Command, reason: str) -> None:
        self.report.unknown.append(self.item(cmd, reason))

    def default(self, key: str, why: str) -> None:
        """Record a value filled in because the macro does not give it."""
        self.report.defaults.append((key, why))

    def set(self, key: str, value: Any, cmd: _Command) -> None:
        """A source/run/physics setting; a later command for the same key overrides (reported)."""
        if key in self.settings:
            old = self.settings[key][1]
            self.ignored(old, f"overridden by {self.where(cmd)}")
        self.settings[key] = (value, cmd)


def _helper_value(cmd: _Command, kind: str) -> Any:
    if kind == "length":
        return _quantity(cmd, "length")
    if kind == "length0":
        return _quantity(cmd, "length", minimum="zero")
    if kind == "count":
        return _count(cmd)
    if kind == "spikeform":
        return _word(cmd, tuple(_SPIKEFORMS))
    return _word(cmd)


def _helper_command(state: _State, cmd: _Command, parts: list[str]) -> None:
    """``/Surface/<Helper>/<name>/<cmd>`` or the paper's short form ``/Surface/<Helper>/<cmd>``."""
    kind = parts[1]
    table, ignored, store = (
        (_ROUGHNESS, _ROUGHNESS_IGNORED, state.rough)
        if kind == "RoughnessHelper"
        else (_PORTAL, _PORTAL_IGNORED, state.portals)
    )
    if len(parts) == 3:
        name, sub = UNNAMED_HELPER, parts[2]
        note = (
            f"/Surface/{kind}/<command> has no helper name (the paper's Listing 4 form; the "
            f"library's path is /Surface/{kind}/<name>/<command>): read as helper "
            f"{UNNAMED_HELPER!r}"
        )
        if note not in state.report.notes:
            state.report.notes.append(note)
    elif len(parts) == 4:
        name, sub = parts[2], parts[3]
    else:
        state.unknown(cmd, "unknown command")
        return
    if sub in ignored:
        state.ignored(cmd, ignored[sub])
        return
    if sub not in table:
        state.unknown(cmd, f"unknown {kind} command")
        return
    if state.initialized is not None:
        state.ignored(
            cmd,
            f"after /run/initialize ({state.where(state.initialized)}): the original reads helper "
            "parameters only in Construct(), which has run, so this had no effect",
        )
        return
    param, value_kind = table[sub]
    store.setdefault(name, _Helper(name)).set(param, _helper_value(cmd, value_kind), cmd)


def _describer_command(state: _State, cmd: _Command, sub: str) -> None:
    if sub not in _DESCRIBER:
        state.unknown(cmd, "unknown /geometry/surface command")
        return
    if state.initialized is not None:
        state.ignored(
            cmd,
            f"after /run/initialize ({state.where(state.initialized)}): no effect in the original",
        )
        return
    param, kind = _DESCRIBER[sub]
    if kind == "describer_form":
        value = _word(cmd)
        if value not in _SPIKEFORMS:
            state.ignored(
                cmd, f"the original's Describer silently ignores the spike form {value!r}"
            )
            return
    else:
        value = _helper_value(cmd, kind)
    state.describer.set(param, value, cmd)


def _gps_command(state: _State, cmd: _Command) -> None:
    p = cmd.path
    if p == "/gps/particle":
        name = _word(cmd)
        if name != "ion":
            from .source.emitters import normalise_particle

            try:
                name = normalise_particle(name)
            except ConfigError as err:
                raise cmd.fail(str(err)) from None
        state.set("particle", name, cmd)
    elif p == "/gps/ion":
        if not 2 <= len(cmd.args) <= 4:
            raise cmd.fail(f"expected 'Z A [Q [E]]', got {' '.join(cmd.args)!r}")
        for i, what in ((0, "Z"), (1, "A")):
            if not _INTEGER.match(cmd.args[i]) or int(cmd.args[i]) < 1:
                raise cmd.fail(f"{what} {cmd.args[i]!r} is not an integer >= 1")
        z, a = int(cmd.args[0]), int(cmd.args[1])
        excitation = cmd.args[3] if len(cmd.args) == 4 else "0"
        if not _NUMBER.match(excitation):
            raise cmd.fail(f"excitation energy {excitation!r} is not a number (keV)")
        if float(excitation) != 0.0:
            state.unknown(
                cmd, "excited ion states are not converted (score4 starts ions in the ground state)"
            )
            return
        state.set("ion", (z, a), cmd)
    elif p in ("/gps/ene/mono", "/gps/energy"):
        # Geant4's default units: keV for /gps/ene/mono, GeV for /gps/energy
        state.set(
            "energy",
            _quantity(cmd, "energy", "keV" if p == "/gps/ene/mono" else "GeV", minimum="zero"),
            cmd,
        )
    elif p == "/gps/ene/type":
        if _word(cmd) == "Mono":
            state.converted(cmd, "source.energy is mono-energetic (score4's particle + energy)")
        else:
            state.unknown(
                cmd,
                f"energy distribution {cmd.args[0]!r} is not converted (only Mono; score4 reads "
                "other spectra from a table: source.spectrum)",
            )
    elif p == "/gps/ang/type":
        if _word(cmd) == "iso":
            state.set("direction", "isotropic", cmd)
        else:
            state.unknown(
                cmd,
                f"angular distribution {cmd.args[0]!r} is not converted (only iso; see "
                "source.direction for inward/outward/cosine/normal relative to the surface)",
            )
    elif p == "/gps/number":
        if _count(cmd) == 1:
            state.converted(cmd, "one primary per vertex (as score4)")
        else:
            state.unknown(cmd, "several primaries per vertex are not converted")
    elif p in _GPS_POSITION:
        state.ignored(cmd, _IGNORED_PREFIX["/gps/pos/"])
    elif p == "/gps/verbose":
        state.ignored(cmd, _VERBOSE)
    elif p in _IGNORED_EXACT:
        state.ignored(cmd, _IGNORED_EXACT[p])
    else:
        state.unknown(cmd, "GPS command not converted")


def _shift_command(state: _State, cmd: _Command) -> None:
    sub = cmd.path.removeprefix("/shift/")
    if sub == "loadShiftTable":
        if len(cmd.args) != 1:
            raise cmd.fail(f"expected one file name, got {' '.join(cmd.args)!r}")
        name = Path(cmd.args[0])
        # The original opens it relative to the program's working folder; try beside the macro
        # first.
        candidates = [name] if name.is_absolute() else [cmd.file.parent / name, Path.cwd() / name]
        found = next((c for c in candidates if c.is_file()), None)
        if found is None:
            raise cmd.fail(
                f"shift table {cmd.args[0]!r} not found (looked in "
                f"{', '.join(str(c.parent) for c in candidates)})"
            )
        state.tables.append((found, cmd))
    elif sub in ("setMinShift", "setMaxShift"):
        q = _quantity(cmd, "length", "mm", minimum="zero" if sub == "setMinShift" else "positive")
        state.set("depth_min" if sub == "setMinShift" else "depth_max", q, cmd)
    elif sub == "confineToMaterial":
        state.set("confine", _word(cmd), cmd)
    elif sub == "verbose":
        state.ignored(cmd, _VERBOSE)
    elif cmd.path in _IGNORED_EXACT:
        state.ignored(cmd, _IGNORED_EXACT[cmd.path])
    else:
        state.unknown(cmd, "unknown /shift command")


def _run_command(state: _State, cmd: _Command) -> bool:
    """/run, /random and /control commands that carry settings; False if not one of them."""
    p = cmd.path
    if p == "/run/beamOn":
        if len(cmd.args) > 1:
            state.unknown(cmd, "a macro executed per event is not converted")
        else:  # Geant4's default: 1 event
            state.beam_on.append((_count(cmd, 0, 0) if cmd.args else 1, cmd))
    elif p == "/run/initialize":
        state.initialized = state.initialized or cmd
        state.ignored(cmd, _IGNORED_EXACT[p])
    elif p == "/run/setCut":
        state.set("cut", _quantity(cmd, "length", "mm"), cmd)
    elif p == "/random/setSeeds":
        if not cmd.args or not all(_INTEGER.match(a) and int(a) >= 0 for a in cmd.args):
            raise cmd.fail(f"{' '.join(cmd.args)!r} are not integers >= 0")
        state.set("seeds", [int(a) for a in cmd.args], cmd)
    elif p == "/control/execute":
        state.converted(cmd, "its commands are read in place")
    else:
        return False
    return True


def _collect(state: _State, commands: list[_Command]) -> None:
    for cmd in commands:
        parts = cmd.path.strip("/").split("/")
        p = cmd.path
        if any("{" in a for a in (p, *cmd.args)) or p.startswith(
            ("/control/alias", "/control/getEnv")
        ):
            state.unknown(cmd, "aliases are not supported; expand them before importing")
        elif (
            parts[0] == "Surface"
            and len(parts) >= 3
            and parts[1] in ("RoughnessHelper", "MultiportalHelper")
        ):
            _helper_command(state, cmd, parts)
        elif p.startswith("/geometry/surface/") and len(parts) == 3:
            _describer_command(state, cmd, parts[2])
        elif p.startswith("/gps/") and not p.startswith(("/gps/pos/", "/gps/ang/rot")):
            _gps_command(state, cmd)
        elif p.startswith("/shift/"):
            _shift_command(state, cmd)
        elif _run_command(state, cmd):
            pass
        elif p in _IGNORED_EXACT:
            state.ignored(cmd, _IGNORED_EXACT[p])
        elif parts[-1] in ("verbose", "setVerbose", "verboseLevel"):
            state.ignored(cmd, _VERBOSE)
        elif prefix := next((k for k in _IGNORED_PREFIX if p.startswith(k)), None):
            state.ignored(cmd, _IGNORED_PREFIX[prefix])
        else:
            state.unknown(cmd, "unknown command")


# --------------------------------------------------------------------------------------------
# Building the configuration
# --------------------------------------------------------------------------------------------


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= _RTOL * max(abs(a), abs(b))


def _spike_surface(state: _State, helper: _Helper, label: str, defaults: dict | None) -> dict:
    """The ``kind: spikes`` description of a helper (``defaults``: values of unset parameters)."""
    values = helper.values

    def value(param: str):
        if param in values:
            return values[param][0]
        if defaults is not None:
            return defaults[param]
        what = {
            "dx": "setSpikeDx",
            "dy": "setSpikeDy",
            "mean": "setSpikeMeanHeight",
            "nx": "setSpikesNx",
            "ny": "setSpikesNy",
        }[param]
        raise ConfigError(
            f"{state.macro}: {label}/{what} is missing; the original's default 0 builds no spike, "
            "so score4 cannot guess it"
        )

    def q(param: str) -> _Quantity:
        v = value(param)
        if isinstance(v, _Quantity):
            return v
        number, unit = v.split()
        return _Quantity(float(number), unit, float(number) * _G4_LENGTH[unit], "length")

    key = f"surfaces.{helper.name}"
    form = value("form") if "form" in values or defaults is not None else "StandardPyramid"
    shape = _SPIKEFORMS[form]
    pyramid = shape == "pyramid"
    # Spike.cc: a pyramid is one G4Trd with half-height dz = MeanHeight centred at z = MeanHeight,
    # so it spans z = 0 .. 2 MeanHeight: full height = 2 x MeanHeight (and the Gaussian sigma of
    # UniformPyramid, drawn on MeanHeight, doubles with it). Bump and Peak stack nLayer layers of
    # height MeanHeight / nLayer: full height = 1 x MeanHeight.
    factor = 2.0 if pyramid else 1.0
    dx, dy, mean = q("dx"), q("dy"), q("mean")
    nx, ny = value("nx"), value("ny")
    spec: dict[str, Any] = {
        "kind": "spikes",
        "nx": nx,
        "ny": ny,
        "width_x": dx.text(2),
        "width_y": dy.text(2),
        "height": mean.text(factor),
        "shape": shape,
    }
    detail = {
        "dx": f"{key}.width_x = {dx.text(2)} (2 x half-width)",
        "dy": f"{key}.width_y = {dy.text(2)} (2 x half-width)",
        "mean": f"{key}.height = {mean.text(factor)} ({'2 x' if pyramid else '1 x'} "
        f"setSpikeMeanHeight: {form} "
        + ("is a G4Trd of half-height MeanHeight)" if pyramid else "layers add up to MeanHeight)"),
        "nx": f"{key}.nx = {nx}",
        "ny": f"{key}.ny = {ny}",
        "form": f"{key}.shape = {shape}"
        + (" (Gaussian heights: height_sigma)" if form == "UniformPyramid" else ""),
        "material": f"targets.0.material = {helper.get('material')} (the rough layer is in its "
        "target's material)",
    }
    reasons: dict[str, str] = {}
    if form == "UniformPyramid":
        dev = q("dev") if "dev" in values or defaults is not None else None
        if dev is not None and dev.value > 0:
            spec["height_sigma"] = dev.text(factor)
            spec["seed"] = 0
            state.default(
                f"{key}.seed",
                "0 (the original draws the spike heights from Geant4's "
                "engine; score4 draws them with numpy from this seed)",
            )
            state.report.notes.append(
                f"{key}: the original clamps Gaussian heights <= 0 to 1e-9 mm (and then aborts in "
                "G4Trd); score4 redraws heights below min_height (default 1 % of the mean), a "
                "truncated Gaussian"
            )
        if dev is not None:
            detail["dev"] = f"{key}.height_sigma = {dev.text(factor)} (2 x, like the height)"
    else:
        reasons["dev"] = (
            f"the original uses the deviation only for UniformPyramid; {form} spikes all have the "
            "mean height"
        )
    if pyramid:
        reasons["nlayer"] = "the original builds pyramids from one G4Trd whatever setNLayer says"
    else:
        spec["n_layers"] = value("nlayer") if "nlayer" in values or defaults is not None else 1
        detail["nlayer"] = f"{key}.n_layers = {spec['n_layers']}"
    if not (_close(dx.value, dy.value)):
        state.report.notes.append(
            f"{key}: spike half-widths differ in x and y ({dx.text()} and {dy.text()}); the "
            "original's RectangleDivider breaks such grids (notes §3.1-1), score4 builds them as "
            "written"
        )
    for param, (_, cmd) in values.items():
        if param in reasons:
            state.ignored(cmd, reasons[param])
        elif param in detail:
            state.converted(cmd, detail[param])
    for param, _, cmd in helper.commands:  # earlier values of repeated commands
        if values[param][1] is not cmd:
            state.ignored(cmd, f"overridden by {state.where(values[param][1])}")
    return spec


def _patch_basis(
    state: _State, helper: _Helper, one_patch: bool
) -> tuple[_Quantity, _Quantity, _Quantity | None]:
    """Check a helper's basis against its spikes (RoughnessHelper::CheckValues).

    Returns the patch half-sizes along x and y and the basis half-height (None if not given).
    ``one_patch``: the face is this single patch (no portal), so the basis sets the face size.
    """
    key = f"surfaces.{helper.name}"
    halves = []
    for i, axis in enumerate(("x", "y")):
        spike, n = helper.get(f"d{axis}"), helper.get(f"n{axis}")
        want = _Quantity(spike.number * n, spike.unit, spike.value * n, "length")
        basis_cmd = helper.cmd(f"basis_d{axis}")
        if basis_cmd is None:
            state.default(
                f"{key}: patch size along {axis}",
                f"{want.text(2)} = setSpikesN{axis} x 2 x "
                f"setSpikeD{axis} (no setBasisD{axis}; the only value the original accepts)",
            )
            halves.append(want)
            continue
        basis = helper.get(f"basis_d{axis}")
        if not _close(basis.value, want.value):
            raise basis_cmd.fail(
                f"basis half-length {basis.text()} must equal setSpikesN{axis} x setSpikeD{axis} = "
                f"{n} x {spike.text()} = {want.text()} (the original exits on this: "
                "RoughnessHelper::CheckValues)"
            )
        where = (
            f"targets.0.size.{i} = {basis.text(2)}"
            if one_patch
            else f"patch size {basis.text(2)} along {axis}"
        )
        state.converted(basis_cmd, f"{where} (2 x half-length; = {key}.n{axis} x width_{axis})")
        halves.append(basis)
    return halves[0], halves[1], helper.get("basis_dz")


def _portal_face(
    state: _State, portal: _Helper, patch: tuple[_Quantity, _Quantity], config: dict, rough: dict
) -> tuple[str, str]:
    """Face size from the portal (checked like MultiportalHelper::CheckValues), converted keys."""
    sizes = []
    for axis, half_patch in zip(("x", "y"), patch, strict=True):
        sub = portal.get(f"sub_d{axis}")
        if sub is not None:
            sub_cmd = portal.set_cmd(f"sub_d{axis}")
            if not _close(sub.value, half_patch.value):
                raise sub_cmd.fail(
                    f"subworld half-size {sub.text()} differs from the roughness patch half-size "
                    f"{half_patch.text()}; score4 tiles patches edge to edge and cannot leave gaps "
                    "or overlaps between them"
                )
            state.converted(
                sub_cmd,
                f"patch size {sub.text(2)} along {axis} (2 x half-length, = the roughness patch)",
            )
        n, n_cmd = portal.get(f"n{axis}"), portal.cmd(f"n{axis}")
        full = portal.get(f"d{axis}")
        if full is None:
            if n is None:
                raise ConfigError(
                    f"{state.macro}: MultiportalHelper {portal.name!r}: give setD{axis}Portal or "
                    f"setN{axis}Subworld: the face size along {axis} is unknown"
                )
            full = _Quantity(half_patch.number * n, half_patch.unit, half_patch.value * n, "length")
            state.default(
                f"face size along {axis}",
                f"{full.text(2)} = setN{axis}Subworld x patch size (no setD{axis}Portal)",
            )
        else:
            full_cmd = portal.set_cmd(f"d{axis}")
            ratio = full.value / half_patch.value
            if not _close(ratio, round(ratio)) or round(ratio) < 1:
                raise full_cmd.fail(
                    f"portal half-size {full.text()} is not a whole number of patch half-sizes "
                    f"({half_patch.text()}): {ratio:.6g}"
                )
            if n is not None and n != round(ratio):
                raise portal.set_cmd(f"n{axis}").fail(
                    f"{n} subworlds x {half_patch.text()} != portal half-size {full.text()} (the "
                    "original exits on this: MultiportalHelper::CheckValues)"
                )
            state.converted(
                full_cmd,
                f"targets.0.size.{'xy'.index(axis)} = {full.text(2)} (2 x half-length: the face)",
            )
        if n_cmd is not None:
            state.converted(n_cmd, f"{n} patches along {axis} (= face size / patch size)")
        sizes.append(full.text(2))
    dz, dz_cmd = portal.get("dz"), portal.cmd("dz")
    sub_dz, sub_dz_cmd = portal.get("sub_dz"), portal.cmd("sub_dz")
    if dz is not None and sub_dz is not None and not _close(dz.value, sub_dz.value):
        raise portal.set_cmd("sub_dz").fail(
            f"subworld half-height {sub_dz.text()} != portal half-height {dz.text()} (the original "
            "exits on this: MultiportalHelper::CheckValues)"
        )
    for c in (dz_cmd, sub_dz_cmd):
        if c is not None:
            state.ignored(
                c, "score4 sizes the rough layer's envelope itself (base_thickness + tallest spike)"
            )
    material_cmd = portal.cmd("material")
    if material_cmd is not None:
        config.setdefault("world", {})["material"] = portal.get("material")
        state.converted(
            material_cmd,
            f"world.material = {portal.get('material')} (the medium around "
            "the patches: score4's layer envelope is of the world material)",
        )
    for param, _, cmd in portal.commands:
        if portal.values[param][1] is not cmd:
            state.ignored(cmd, f"overridden by {state.where(portal.values[param][1])}")
    rough["tiling"] = "portal"
    return sizes[0], sizes[1]


def _relative(path: Path, folder: Path) -> str:
    """``path`` relative to ``folder`` (how score4 resolves config paths), or absolute if they share
    only the root."""
    path, folder = path.resolve(), folder.resolve()
    try:
        common = Path(os.path.commonpath([path, folder]))
    except ValueError:  # another drive (Windows)
        return str(path)
    return str(path) if common.parent == common else os.path.relpath(path, folder)


def _depth(state: _State, out_dir: Path, stem: str) -> dict | None:
    """``source.depth`` from the /shift/ commands, or None (vertices on the surface)."""
    from .source.sampling import read_table

    mn, mx = state.settings.get("depth_min"), state.settings.get("depth_max")
    if not state.tables:
        for entry in (mn, mx):
            if entry is not None:
                state.ignored(
                    entry[1],
                    "no /shift/loadShiftTable: the original does not shift without a table",
                )
        return None
    depth: dict[str, Any] = {"profile": "table"}
    if len(state.tables) == 1:
        table, cmd = state.tables[0]
        try:
            depths, _ = read_table(table, "length", unit="nm", what="shift table", xname="depth")
        except ConfigError as err:
            raise cmd.fail(
                f"{err} (score4 reads the original's 'depth,weight' rows in nm)"
            ) from None
        depth["file"] = _relative(table, out_dir)
        depth["unit"] = "nm"
        state.converted(cmd, f"source.depth: profile table, file {depth['file']}, unit nm")
    else:
        # The original appends each table to the previous ones (PointShift::LoadShiftTable).
        rows = []
        for table, cmd in state.tables:
            try:
                rows.append(
                    f"# from {table} ({state.where(cmd)})\n" + table.read_text().rstrip("\n") + "\n"
                )
            except (OSError, UnicodeDecodeError) as err:
                raise cmd.fail(f"cannot read {str(table)!r} ({err})") from None
        name = f"{stem}.depth.txt"
        text = (
            f"# depth table merged by score4 import-macro from {len(rows)} /shift/loadShiftTable "
            "files,\n# in the order the original appends them; columns: depth, weight\n# unit: "
            "nm\n" + "".join(rows)
        )
        with tempfile.TemporaryDirectory() as folder:
            check = Path(folder) / name
            check.write_text(text)
            try:
                depths, _ = read_table(check, "length", what="merged shift table", xname="depth")
            except ConfigError as err:
                raise state.tables[1][1].fail(
                    f"the tables cannot be merged as the original appends them: "
                    f"{str(err).replace(str(check), name)}"
                ) from None
        state.report.files[name] = text
        depth["file"] = name
        for _, cmd in state.tables:
            state.converted(cmd, f"source.depth: profile table, merged into {name}")
        state.report.notes.append(
            f"the original appends every loaded table to the previous ones; {name} holds them "
            "merged in that order"
        )
    steps = np.diff(depths)
    if len(steps) and not all(_close(s, steps[0]) for s in steps):
        state.report.notes.append(
            "the shift table's depths are not equally spaced: the original weights its bins "
            "without their widths (notes §3.1-16), score4 samples the true piecewise-linear "
            "density through the points, so the two differ"
        )
    if mn is not None and mx is not None and mx[0].value <= mn[0].value:
        raise mx[1].fail(
            f"the maximum shift {mx[0].text()} must be larger than the minimum {mn[0].text()} "
            f"({state.where(mn[1])})"
        )
    for key, entry in (("min", mn), ("max", mx)):
        if entry is not None:
            depth[key] = entry[0].text()
            state.converted(entry[1], f"source.depth.{key} = {entry[0].text()}")
    depth["definition"] = "normal"
    state.report.notes.append(
        "the original applies /shift/ settings only when its C++ builds the sampler with a shift "
        "file (notes §3.1-17); score4 applies them"
    )
    return depth


def _source(
    state: _State, config: dict, target: str, material: str, out_dir: Path, stem: str
) -> None:
    s = state.settings
    source: dict[str, Any] = {"surface": {"volume": target, "face": "+z"}}
    state.default(
        "source.surface",
        f"{{volume: {target}, face: +z}} (the original samples the "
        "rough surface; score4 names the face it covers)",
    )
    particle = s.get("particle")
    energy = s.get("energy")
    if particle is None:
        source["particle"] = "geantino"
        state.default("source.particle", "geantino (GPS default; the macro has no /gps/particle)")
    elif particle[0] == "ion":
        ion = s.get("ion")
        if ion is None:
            raise particle[1].fail("'ion' needs /gps/ion Z A to say which ion")
        from .source.emitters import ELEMENTS

        z, a = ion[0]
        if z > len(ELEMENTS) or a < z:
            raise ion[1].fail(f"no nuclide with Z = {z} and A = {a}")
        nuclide = f"{ELEMENTS[z - 1]}{a}"
        if energy is not None and energy[0].value == 0:
            source["nuclide"] = nuclide
            state.converted(
                particle[1],
                f"source.nuclide = {nuclide} (with /gps/ion; an ion at rest decays: "
                "Geant4 radioactive decay, needs full physics)",
            )
            state.converted(ion[1], f"source.nuclide = {nuclide}")
            state.converted(energy[1], "energy 0: the ion is at rest (source.nuclide)")
            energy = None
        else:
            source["particle"] = nuclide
            state.converted(particle[1], f"source.particle = {nuclide} (with /gps/ion)")
            state.converted(ion[1], f"source.particle = {nuclide}")
    else:
        source["particle"] = particle[0]
        state.converted(particle[1], f"source.particle = {particle[0]}")
        if s.get("ion") is not None:
            state.ignored(s["ion"][1], f"/gps/particle is {particle[0]}, not ion")
    if "particle" in source:
        if energy is None:
            source["energy"] = "1 MeV"
            state.default("source.energy", "1 MeV (GPS default; the macro sets no energy)")
        elif energy[0].value == 0:
            raise energy[1].fail("score4 needs a positive energy for a particle source")
        else:
            source["energy"] = energy[0].text()
            state.converted(energy[1], f"source.energy = {energy[0].text()}")
    direction = s.get("direction")
    source["direction"] = "isotropic"
    if direction is None:
        state.default(
            "source.direction",
            "isotropic (the macro has no /gps/ang/type; GPS's own default is one fixed direction)",
        )
    else:
        state.converted(direction[1], "source.direction = isotropic")
    depth = _depth(state, out_dir, stem)
    if depth is not None:
        source["depth"] = depth
        confine = s.get("confine")
        if confine is None:
            state.default(
                "source.confine",
                "true (score4 keeps shifted vertices in the target's "
                "material; the original confines only with /shift/confineToMaterial)",
            )
        else:
            if confine[0] != material:
                raise confine[1].fail(
                    f"no converted volume is made of {confine[0]!r}: the target is {material}"
                )
            source["confine"] = confine[0]
            state.converted(confine[1], f"source.confine = {confine[0]}")
    elif s.get("confine") is not None:
        state.ignored(s["confine"][1], "no /shift/loadShiftTable: vertices stay on the surface")
    config["source"] = source


def _run(state: _State, config: dict) -> None:
    run: dict[str, Any] = {}
    if state.beam_on:
        run["events"] = sum(n for n, _ in state.beam_on)
        for _, cmd in state.beam_on:
            state.converted(
                cmd,
                f"run.events = {run['events']}"
                + (f" (sum of {len(state.beam_on)} runs)" if len(state.beam_on) > 1 else ""),
            )
        if len(state.beam_on) > 1:
            state.report.notes.append(
                f"{len(state.beam_on)} /run/beamOn commands: one score4 run of all their events"
            )
        if run["events"] < 1:
            raise state.beam_on[-1][1].fail("no events: score4 needs run.events >= 1")
    else:
        run["events"] = 1000
        state.default("run.events", "1000 (score4's default; the macro has no /run/beamOn)")
    seeds = state.settings.get("seeds")
    if seeds is None:
        run["seed"] = 1
        state.default("run.seed", "1 (score4's default; the macro has no /random/setSeeds)")
    else:
        values, cmd = seeds
        seed = 0
        for v in values:  # one seed as it is; several folded into one 63-bit number
            seed = (seed * 2**32 + v) % 2**63
        run["seed"] = seed
        how = (
            ""
            if len(values) == 1
            else f" (= {' x 2^32 + '.join(map(str, values))}, folded: score4 takes one seed)"
        )
        state.converted(cmd, f"run.seed = {seed}{how}")
    config["run"] = run
    cut = state.settings.get("cut")
    if cut is not None:
        config["physics"] = {"production_cut": cut[0].text()}
        state.converted(cut[1], f"physics.production_cut = {cut[0].text()}")


def _surfaces(state: _State) -> list[_Helper]:
    """The helpers that describe surfaces: the RoughnessHelpers, else the Describer
    (/geometry/surface)."""
    if state.rough:
        for _, _, cmd in state.describer.commands:
            state.ignored(
                cmd,
                "overridden: RoughnessHelper copies its own parameters into the Describer "
                "(RoughnessHelper::BuildSurface)",
            )
        return list(state.rough.values())
    if state.describer.commands:
        state.default(
            "surfaces.surface",
            "unset /geometry/surface values take the Describer's "
            "defaults (half-width 0.005 mm, 1 x 1 spikes, mean height 0.005 mm, sigma 1 mm)",
        )
        return [state.describer]
    raise ConfigError(
        f"{state.macro}: no rough surface: the macro has no /Surface/RoughnessHelper/... or "
        "/geometry/surface/... commands, so there is nothing to convert"
    )


def _face(state: _State, helpers: list[_Helper], config: dict) -> tuple[dict, str, str]:
    """The rough face (``targets.0.rough.0``) and the face size along x and y."""
    first = helpers[0]
    portals = list(state.portals.values())
    placed = helpers if portals else helpers[:1]
    rough: dict[str, Any] = {"face": "+z"}
    state.default("targets.0.rough.0.face", "+z (spikes point along +z in the original's patch)")
    if first is state.describer:
        patch = []
        for axis in ("x", "y"):
            n = first.get(f"n{axis}", _DESCRIBER_DEFAULTS[f"n{axis}"])
            half = first.get(f"d{axis}") or _DEFAULT_DESCRIBER_WIDTH
            patch.append(_Quantity(half.number * n, half.unit, half.value * n, "length"))
        base = None
    else:
        bases = {h.name: _patch_basis(state, h, one_patch=not portals) for h in helpers}
        *patch, base = bases[first.name]
        for h in placed[1:]:  # variants of one face: one patch size, one base thickness
            *other, other_base = bases[h.name]
            for axis, a, b in zip(("x", "y"), patch, other, strict=True):
                if not _close(a.value, b.value):
                    raise h.set_cmd(f"d{axis}").fail(
                        f"the patch of {h.name!r} is {2 * b.value:g} mm along {axis}, that of "
                        f"{first.name!r} {2 * a.value:g} mm; the patches of one face must have one "
                        "size"
                    )
            mismatch = (
                (base is None) != (other_base is None)
                if base is None or other_base is None
                else not _close(base.value, other_base.value)
            )
            if mismatch:
                c = h.cmd("basis_dz") or first.set_cmd("basis_dz")
                raise c.fail(
                    f"{h.name!r} and {first.name!r} have different basis heights; a score4 rough "
                    "face has one base_thickness"
                )
    if base is not None:
        rough["base_thickness"] = base.text(2)
        for h in helpers:
            basis_cmd = h.cmd("basis_dz")
            if basis_cmd is not None:
                state.converted(
                    basis_cmd,
                    f"targets.0.rough.0.base_thickness = {base.text(2)} (2 x half-height)",
                )
    else:
        state.default(
            "targets.0.rough.0.base_thickness",
            "1 um (score4's default; the macro gives no basis height)",
        )
    for extra in portals[1:]:
        for _, _, cmd in extra.commands:
            state.unknown(
                cmd,
                f"a second MultiportalHelper ({extra.name!r}): score4 converts one portal per "
                "macro",
            )
    if portals:
        size_x, size_y = _portal_face(state, portals[0], (patch[0], patch[1]), config, rough)
    else:
        size_x, size_y = patch[0].text(2), patch[1].text(2)
        state.report.notes.append(
            "no MultiportalHelper: the face is one patch (targets.0.size = the patch size)"
        )
    if len(placed) > 1:
        rough["variants"] = [
            {"surface": h.name, "density": round(1 / len(placed), 12)} for h in placed
        ]
        rough["fill"] = "exact"
        state.default(
            "targets.0.rough.0.variants",
            f"{len(placed)} patches with equal densities "
            "(the original sets them in C++, AddSubworldDensity; edit them here)",
        )
        state.default(
            "targets.0.rough.0.fill",
            "exact (the realised fractions equal the densities; "
            "the original draws each cell independently, like fill: random)",
        )
    else:
        rough["surface"] = first.name
    if len(helpers) > len(placed):
        state.report.notes.append(
            f"several RoughnessHelpers and no portal: only {first.name!r} is placed; "
            f"{', '.join(h.name for h in helpers[1:])} are defined under surfaces (the "
            "original places them in C++)"
        )
    order = ("face", "surface", "variants", "fill", "tiling", "base_thickness")
    return {k: rough[k] for k in order if k in rough}, size_x, size_y


def _material(state: _State, placed: list[_Helper]) -> str:
    """The target material: the placed patches' one material (a score4 layer is in its target's)."""
    given = {h.name: h.get("material") for h in placed if h.get("material") is not None}
    if len(set(given.values())) > 1:
        names = ", ".join(f"{n}: {m}" for n, m in given.items())
        raise ConfigError(
            f"{state.macro}: the patches have different materials ({names}); a score4 rough face "
            "is in its target's one material"
        )
    if not given:
        state.default("targets.0.material", f"{DEFAULT_MATERIAL} (no setMaterial)")
        return DEFAULT_MATERIAL
    return next(iter(given.values()))


def _build(state: _State, out_dir: Path, stem: str) -> dict:
    config: dict[str, Any] = {}
    helpers = _surfaces(state)
    config["surfaces"] = {}
    for h in helpers:
        label = (
            f"/Surface/RoughnessHelper/{h.name}"
            if h is not state.describer
            else "/geometry/surface"
        )
        config["surfaces"][h.name] = _spike_surface(
            state, h, label, _DESCRIBER_DEFAULTS if h is state.describer else None
        )
    rough, size_x, size_y = _face(state, helpers, config)
    material = _material(state, helpers if state.portals else helpers[:1])
    thickness = parse_quantity(DEFAULT_TARGET_THICKNESS, "length")
    config["targets"] = [
        {
            "name": DEFAULT_TARGET,
            "material": material,
            "size": [size_x, size_y, DEFAULT_TARGET_THICKNESS],
            "position": ["0 mm", "0 mm", f"{_g(-thickness / 2)} mm"],
            "rough": [rough],
        }
    ]
    state.default(
        "targets.0",
        f"a {material} block named {DEFAULT_TARGET!r}, "
        f"{DEFAULT_TARGET_THICKNESS} thick, under the rough face, with the face at z = 0 "
        "(the original builds the volume under the surface in C++)",
    )
    _source(state, config, DEFAULT_TARGET, material, out_dir, stem)
    _run(state, config)
    order = ("physics", "world", "surfaces", "targets", "source", "run")
    return {k: config[k] for k in order if k in config}


# --------------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------------


def import_macro(
    path: str | os.PathLike, out: str | os.PathLike | None = None
) -> tuple[dict, ImportReport]:
    """Convert an original SCoRe4 macro into a score4 run configuration.

    Parameters
    ----------
    path
        The macro (``.mac``). ``/control/execute`` macros are read in place.
    out
        Where the configuration will be written; relative file paths in it (the depth table)
        are made relative to its folder. Default: beside the macro.

    Returns
    -------
    config, report
        ``config`` validates with :func:`score4.config.parse_config` (checked here, with
        ``base_dir`` = the output folder); ``report`` accounts for every command.

    Raises
    ------
    ConfigError
        Missing or unreadable file, a value that cannot be read ("<file> line 12: <command>:
        'abc' is not a length ..."), sizes the original itself refuses, or a macro without any
        rough surface.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(
            f"FILE.mac: {str(path)!r} does not exist"
            if not path.exists()
            else f"FILE.mac: {str(path)!r} is not a file"
        )
    out_path = Path(out) if out is not None else path.with_suffix(".yaml")
    out_dir = out_path.parent
    commands: list[_Command] = []
    _read(path, commands, (path,))
    report = ImportReport(macro=path)
    state = _State(path, report)
    _collect(state, commands)
    config = _build(state, out_dir, out_path.name.removesuffix(".yaml").removesuffix(".yml"))
    parse_config(config, origin=f"{out_path} (converted from {path})", base_dir=out_dir)
    return config, report


class _Dumper(yaml.SafeDumper):
    """Block-style mappings; lists of plain values (sizes, positions) on one line."""


_Dumper.add_representer(
    list,
    lambda d, v: d.represent_sequence(
        "tag:yaml.org,2002:seq", v, flow_style=not any(isinstance(x, (dict, list)) for x in v)
    ),
)


def render_yaml(config: dict, report: ImportReport) -> str:
    """The configuration as YAML under a comment header: source macro, date, the report."""
    from . import __version__

    now = dt.datetime.now().astimezone().isoformat(timespec="seconds")
    header = [
        "score4 run configuration converted from an original SCoRe4 macro by 'score4 import-macro'",
        f"source macro: {report.macro.resolve()}",
        f"date:         {now} (score4 {__version__})",
        "",
        "Lengths: the original's setters take HALF-lengths; score4 uses FULL lengths everywhere,",
        "so every length below is twice the macro's, and a pyramid is 2 x setSpikeMeanHeight high",
        "(a G4Trd of that half-height); Bump/Peak heights are 1 x setSpikeMeanHeight.",
        "See docs/import-macro.md.",
        "",
        *report.lines(),
    ]
    body = yaml.dump(
        config,
        Dumper=_Dumper,
        sort_keys=False,
        default_flow_style=False,
        width=110,
        allow_unicode=True,
    )
    return "".join(f"# {line}".rstrip() + "\n" for line in header) + "\n" + body


def write_config(
    config: dict, report: ImportReport, out: str | os.PathLike, overwrite: bool = False
) -> list[Path]:
    """Write the configuration (and any table in ``report.files``) beside each other; return the
    paths.

    Raises
    ------
    ConfigError
        An output file exists and ``overwrite`` is false, or its folder does not exist.
    """
    from .files import atomic_output, check_output_file

    out = Path(out)
    targets = [out] + [out.parent / name for name in report.files]
    for t in targets:
        check_output_file(t, overwrite, "--out")
    texts = [render_yaml(config, report), *report.files.values()]
    for target, text in zip(
        targets[1:], texts[1:], strict=True
    ):  # tables first: the config refers to them
        with atomic_output(target) as tmp:
            tmp.write_text(text)
    with atomic_output(out) as tmp:
        tmp.write_text(texts[0])
    return targets
