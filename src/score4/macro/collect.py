"""Sorting the macro's commands: helper parameters, source / run / physics settings, and a report
entry for every command that carries none (ignored with the reason, or not converted).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from .reader import INTEGER, NUMBER, Command, count, quantity, word
from .report import ImportReport, ReportItem
from .tables import (
    DESCRIBER,
    GPS_POSITION,
    IGNORED_EXACT,
    IGNORED_PREFIX,
    PORTAL,
    PORTAL_IGNORED,
    ROUGHNESS,
    ROUGHNESS_IGNORED,
    SPIKEFORMS,
    VERBOSE,
)

#: Name given to a helper written in the paper's short form ``/Surface/RoughnessHelper/<cmd>``
#: (Listing 4 of the paper omits the helper name that the real library puts in the path).
UNNAMED_HELPER = "rough"


@dataclass
class Helper:
    """The commands given to one helper (last value wins), in macro order."""

    name: str
    commands: list[tuple[str, Any, Command]] = field(default_factory=list)

    def set(self, param: str, value: Any, cmd: Command) -> None:
        self.commands.append((param, value, cmd))

    @property
    def values(self) -> dict[str, tuple[Any, Command]]:
        return {p: (v, c) for p, v, c in self.commands}

    def get(self, param: str, default: Any = None) -> Any:
        v = self.values.get(param)
        return default if v is None else v[0]

    def set_cmd(self, param: str) -> Command:
        """The command that set ``param``; only for parameters :meth:`get` found."""
        c = self.cmd(param)
        if c is None:
            raise KeyError(f"{self.name}: {param} was never set")
        return c

    def cmd(self, param: str) -> Command | None:
        v = self.values.get(param)
        return None if v is None else v[1]


@dataclass
class State:
    macro: Path
    report: ImportReport
    rough: dict[str, Helper] = field(default_factory=dict)
    portals: dict[str, Helper] = field(default_factory=dict)
    describer: Helper = field(default_factory=lambda: Helper("surface"))
    settings: dict[str, tuple[Any, Command]] = field(
        default_factory=dict
    )  # source/run/physics values
    tables: list[tuple[Path, Command]] = field(default_factory=list)
    beam_on: list[tuple[int, Command]] = field(default_factory=list)
    initialized: Command | None = None
    step_limited: set[str] = field(default_factory=set)  # RoughnessHelpers given setStepLimit

    def where(self, cmd: Command) -> str:
        return f"line {cmd.line}" if cmd.file == self.macro else f"{cmd.file.name} line {cmd.line}"

    def item(self, cmd: Command, detail: str) -> ReportItem:
        return ReportItem(self.where(cmd), cmd.text, detail, cmd.order)

    def converted(self, cmd: Command, detail: str) -> None:
        self.report.converted.append(self.item(cmd, detail))

    def ignored(self, cmd: Command, reason: str) -> None:
        self.report.ignored.append(self.item(cmd, reason))

    def unknown(self, cmd: Command, reason: str) -> None:
        self.report.unknown.append(self.item(cmd, reason))

    def default(self, key: str, why: str) -> None:
        """Record a value filled in because the macro does not give it."""
        self.report.defaults.append((key, why))

    def set(self, key: str, value: Any, cmd: Command) -> None:
        """A source/run/physics setting; a later command for the same key overrides (reported)."""
        if key in self.settings:
            old = self.settings[key][1]
            self.ignored(old, f"overridden by {self.where(cmd)}")
        self.settings[key] = (value, cmd)


def _helper_value(cmd: Command, kind: str) -> Any:
    if kind == "length":
        return quantity(cmd, "length")
    if kind == "length0":
        return quantity(cmd, "length", minimum="zero")
    if kind == "count":
        return count(cmd)
    if kind == "spikeform":
        return word(cmd, tuple(SPIKEFORMS))
    return word(cmd)


def _helper_command(state: State, cmd: Command, parts: list[str]) -> None:
    """``/Surface/<Helper>/<name>/<cmd>`` or the paper's short form ``/Surface/<Helper>/<cmd>``."""
    kind = parts[1]
    table, ignored, store = (
        (ROUGHNESS, ROUGHNESS_IGNORED, state.rough)
        if kind == "RoughnessHelper"
        else (PORTAL, PORTAL_IGNORED, state.portals)
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
        if sub == "setStepLimit":
            state.step_limited.add(name)
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
    store.setdefault(name, Helper(name)).set(param, _helper_value(cmd, value_kind), cmd)


def _describer_command(state: State, cmd: Command, sub: str) -> None:
    if sub not in DESCRIBER:
        state.unknown(cmd, "unknown /geometry/surface command")
        return
    if state.initialized is not None:
        state.ignored(
            cmd,
            f"after /run/initialize ({state.where(state.initialized)}): no effect in the original",
        )
        return
    param, kind = DESCRIBER[sub]
    if kind == "describer_form":
        value = word(cmd)
        if value not in SPIKEFORMS:
            state.ignored(
                cmd, f"the original's Describer silently ignores the spike form {value!r}"
            )
            return
    else:
        value = _helper_value(cmd, kind)
    state.describer.set(param, value, cmd)


def _gps_command(state: State, cmd: Command) -> None:
    p = cmd.path
    if p == "/gps/particle":
        name = word(cmd)
        if name != "ion":
            from ..source.emitters import normalise_particle

            try:
                name = normalise_particle(name)
            except ConfigError as err:
                raise cmd.fail(str(err)) from None
        state.set("particle", name, cmd)
    elif p == "/gps/ion":
        if not 2 <= len(cmd.args) <= 4:
            raise cmd.fail(f"expected 'Z A [Q [E]]', got {' '.join(cmd.args)!r}")
        for i, what in ((0, "Z"), (1, "A")):
            if not INTEGER.match(cmd.args[i]) or int(cmd.args[i]) < 1:
                raise cmd.fail(f"{what} {cmd.args[i]!r} is not an integer >= 1")
        z, a = int(cmd.args[0]), int(cmd.args[1])
        excitation = cmd.args[3] if len(cmd.args) == 4 else "0"
        if not NUMBER.match(excitation):
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
            quantity(cmd, "energy", "keV" if p == "/gps/ene/mono" else "GeV", minimum="zero"),
            cmd,
        )
    elif p == "/gps/ene/type":
        if word(cmd) == "Mono":
            state.converted(cmd, "source.energy is mono-energetic (score4's particle + energy)")
        else:
            state.unknown(
                cmd,
                f"energy distribution {cmd.args[0]!r} is not converted (only Mono; score4 reads "
                "other spectra from a table: source.spectrum)",
            )
    elif p == "/gps/ang/type":
        if word(cmd) == "iso":
            state.set("direction", "isotropic", cmd)
        else:
            state.unknown(
                cmd,
                f"angular distribution {cmd.args[0]!r} is not converted (only iso; see "
                "source.direction for inward/outward/cosine/normal relative to the surface)",
            )
    elif p == "/gps/number":
        if count(cmd) == 1:
            state.converted(cmd, "one primary per vertex (as score4)")
        else:
            state.unknown(cmd, "several primaries per vertex are not converted")
    elif p in GPS_POSITION:
        state.ignored(cmd, IGNORED_PREFIX["/gps/pos/"])
    elif p == "/gps/verbose":
        state.ignored(cmd, VERBOSE)
    elif p in IGNORED_EXACT:
        state.ignored(cmd, IGNORED_EXACT[p])
    else:
        state.unknown(cmd, "GPS command not converted")


def _shift_command(state: State, cmd: Command) -> None:
    sub = cmd.path.removeprefix("/shift/")
    if sub == "loadShiftTable":
        if len(cmd.args) != 1:
            raise cmd.fail(f"expected one file name, got {' '.join(cmd.args)!r}")
        # The original opens it relative to the program's working folder; try beside the macro
        # first.
        state.tables.append((cmd.find_file("shift table"), cmd))
    elif sub in ("setMinShift", "setMaxShift"):
        q = quantity(cmd, "length", "mm", minimum="zero" if sub == "setMinShift" else "positive")
        state.set("depth_min" if sub == "setMinShift" else "depth_max", q, cmd)
    elif sub == "confineToMaterial":
        state.set("confine", word(cmd), cmd)
    elif sub == "verbose":
        state.ignored(cmd, VERBOSE)
    elif cmd.path in IGNORED_EXACT:
        state.ignored(cmd, IGNORED_EXACT[cmd.path])
    else:
        state.unknown(cmd, "unknown /shift command")


def _run_command(state: State, cmd: Command) -> bool:
    """/run, /random and /control commands that carry settings; False if not one of them."""
    p = cmd.path
    if p == "/run/beamOn":
        if len(cmd.args) > 1:
            state.unknown(cmd, "a macro executed per event is not converted")
        else:  # Geant4's default: 1 event
            state.beam_on.append((count(cmd, 0, 0) if cmd.args else 1, cmd))
    elif p == "/run/initialize":
        state.initialized = state.initialized or cmd
        state.ignored(cmd, IGNORED_EXACT[p])
    elif p == "/run/setCut":
        state.set("cut", quantity(cmd, "length", "mm"), cmd)
    elif p == "/random/setSeeds":
        if not cmd.args or not all(INTEGER.match(a) and int(a) >= 0 for a in cmd.args):
            raise cmd.fail(f"{' '.join(cmd.args)!r} are not integers >= 0")
        state.set("seeds", [int(a) for a in cmd.args], cmd)
    elif p == "/control/execute":
        state.converted(cmd, "its commands are read in place")
    else:
        return False
    return True


def collect(state: State, commands: list[Command]) -> None:
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
        elif p in IGNORED_EXACT:
            state.ignored(cmd, IGNORED_EXACT[p])
        elif parts[-1] in ("verbose", "setVerbose", "verboseLevel"):
            state.ignored(cmd, VERBOSE)
        elif prefix := next((k for k in IGNORED_PREFIX if p.startswith(k)), None):
            state.ignored(cmd, IGNORED_PREFIX[prefix])
        else:
            state.unknown(cmd, "unknown command")
