"""When, on what and under which load a benchmark ran: printed with its figures, so the docs
that quote them (docs/checks.yaml, slow checks) quote the date and load alongside."""

from __future__ import annotations

import datetime as dt
import os
import platform


def stamp() -> str:
    """``measured 2026-11-25 on 2 cores (x86_64), load 1.3 at the start``."""
    return (
        f"measured {dt.datetime.now(dt.UTC).date().isoformat()} on {os.cpu_count()} cores "
        f"({platform.machine()}), load {os.getloadavg()[0]:.1f} at the start"
    )
