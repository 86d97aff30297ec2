"""The import report: what became of each macro command (converted, ignored, not converted),
the defaults filled in, notes, and the files to write beside the configuration.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


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
