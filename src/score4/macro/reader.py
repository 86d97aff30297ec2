"""Reading a Geant4 macro: tokens, continuation lines, ``/control/execute`` includes, and the
values of the commands (quantities with Geant4 units, counts, words) as :class:`Command` records.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from score4.common.units import ENERGY as SCORE4_ENERGY
from score4.common.units import LENGTH as SCORE4_LENGTH

from ..errors import ConfigError

# --------------------------------------------------------------------------------------------
# Geant4 units (G4UnitDefinition names and symbols), factor to score4's internal unit
# --------------------------------------------------------------------------------------------

G4_LENGTH = {  # symbol -> mm; names map to symbols below
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
    "length": (G4_LENGTH, _G4_LENGTH_NAMES, SCORE4_LENGTH, "mm"),
    "energy": (_G4_ENERGY, _G4_ENERGY_NAMES, SCORE4_ENERGY, "MeV"),
}

NUMBER = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?$")
INTEGER = re.compile(r"^[+-]?\d+$")


@dataclass(frozen=True)
class Quantity:
    """A value read from the macro: number and Geant4 unit symbol as written, and internal value."""

    number: float
    unit: str
    value: float  # mm or MeV
    dimension: str

    def text(self, factor: float = 1.0) -> str:
        """``"<factor x number> <unit>"`` in a unit score4 reads (the macro's own when possible)."""
        _, _, score4_units, internal = _UNITS[self.dimension]
        if self.unit in score4_units:
            return f"{number_text(self.number * factor)} {self.unit}"
        return f"{number_text(self.value * factor)} {internal}"


def number_text(x: float) -> str:
    """``x`` to 12 significant digits, without trailing zeros (how converted values are written)."""
    return f"{x:.12g}"


# --------------------------------------------------------------------------------------------
# Reading the macro
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Command:
    """One macro command: where it is, its path and arguments."""

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

    def find_file(self, what: str) -> Path:
        """The file named by the first argument: as given if absolute, else beside the macro,
        then in the working folder (``what`` names it in the error)."""
        name = Path(self.args[0])
        candidates = [name] if name.is_absolute() else [self.file.parent / name, Path.cwd() / name]
        found = next((c for c in candidates if c.is_file()), None)
        if found is None:
            raise self.fail(
                f"{what} {self.args[0]!r} not found (looked in "
                f"{', '.join(str(c.parent) for c in candidates)})"
            )
        return found


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


def read_macro(path: Path) -> list[Command]:
    """The commands of the macro at ``path`` in execution order (included macros expanded)."""
    commands: list[Command] = []
    _read(path, commands, (path,))
    return commands


def _read(path: Path, commands: list[Command], stack: tuple[Path, ...]) -> None:
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
        cmd = Command(path, first, cmd_path, tuple(pending[1:]), len(commands))
        pending = []
        if cmd.path == "/control/execute":
            _include(cmd, commands, stack)
        else:
            commands.append(cmd)
    if pending:
        raise ConfigError(
            f"{path} line {first}: the last command ends with a continuation mark '_'"
        )


def _include(cmd: Command, commands: list[Command], stack: tuple[Path, ...]) -> None:
    """Expand ``/control/execute FILE`` in place (FILE looked for beside the macro, then here)."""
    if len(cmd.args) != 1:
        raise cmd.fail(f"expected one macro file name, got {' '.join(cmd.args)!r}")
    found = cmd.find_file("macro")
    if found.resolve() in {p.resolve() for p in stack}:
        raise cmd.fail(f"macro {cmd.args[0]!r} executes itself (a loop)")
    commands.append(cmd)  # reported as converted: its commands follow
    _read(found, commands, (*stack, found))


# --------------------------------------------------------------------------------------------
# Values
# --------------------------------------------------------------------------------------------


def quantity(
    cmd: Command,
    dimension: str,
    default_unit: str | None = None,
    index: int = 0,
    minimum: str = "positive",
) -> Quantity:
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
    if not NUMBER.match(args[0]):
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
    return Quantity(number, unit, value, dimension)


def count(cmd: Command, minimum: int = 1, index: int = 0) -> int:
    value = cmd.args[index] if len(cmd.args) > index else ""
    if len(cmd.args) != index + 1 or not INTEGER.match(value) or int(value) < minimum:
        raise cmd.fail(f"{' '.join(cmd.args[index:])!r} is not an integer >= {minimum}")
    return int(value)


def word(cmd: Command, choices: tuple[str, ...] | None = None) -> str:
    if len(cmd.args) != 1:
        raise cmd.fail(f"expected one word, got {' '.join(cmd.args)!r}")
    value = cmd.args[0]
    if choices is not None and value not in choices:
        raise cmd.fail(
            f"{value!r} is not one of {', '.join(choices)} (the original exits on any other value)"
        )
    return value
