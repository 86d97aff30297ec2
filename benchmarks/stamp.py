"""When, on what and under which load a benchmark ran: printed with its figures, so the docs
that quote them (docs/checks.yaml, slow checks) quote the date and load alongside; and the run of
one benchmark case in a child process of its own."""

from __future__ import annotations

import datetime as dt
import os
import platform
import subprocess


def stamp() -> str:
    """``measured 2026-11-25 on 2 cores (x86_64), load 1.3 at the start``."""
    return (
        f"measured {dt.datetime.now(dt.UTC).date().isoformat()} on {os.cpu_count()} cores "
        f"({platform.machine()}), load {os.getloadavg()[0]:.1f} at the start"
    )


def child_figures(cmd: list[str], tag: str) -> tuple[float, ...] | str:
    """Run ``cmd`` (a benchmark case in a fresh process: Geant4 state is per process) and return
    the numbers of its last output line that starts with ``tag``, or the reason it failed."""
    r = subprocess.run(cmd, check=False, capture_output=True, text=True)
    lines = [x for x in r.stdout.splitlines() if x.startswith(f"{tag} ")]
    if r.returncode or not lines:
        return f"failed: {r.stderr.strip().splitlines()[-1:]}"
    return tuple(map(float, lines[-1].split()[1:]))
