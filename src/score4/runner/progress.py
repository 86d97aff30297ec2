"""Progress on stderr: a tqdm bar on a terminal, plain lines in batch logs.

A batch job or a cluster log has no terminal: a tqdm bar there is either nothing or a stream of
carriage returns. :func:`progress_bar` gives a tqdm bar when the stream is a terminal and a
:class:`PlainProgress` otherwise, which writes one line at the start, one each time another
tenth of the work is done or a minute has passed, and one at the end::

    run: 0 of 20000 events (0 %)
    run: 2000 of 20000 events (10 %), 12 s, 167 events/s, about 1 min 48 s left
    ...
    run: 20000 of 20000 events (100 %) in 2 min 2 s

Both have ``update(n)``, ``unpause()`` (time since the last call is left out of the rate, e.g. a
TRIM library being built) and ``close()``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

#: Plain lines: one per this fraction of the work, and at least one per this many seconds.
STEP_FRACTION = 0.1
STEP_SECONDS = 60.0


def duration_text(seconds: float) -> str:
    """``"1 h 2 min"``, ``"3 min 5 s"``, ``"12 s"``."""
    s = round(max(seconds, 0.0))
    if s >= 3600:
        return f"{s // 3600} h {s % 3600 // 60} min"
    if s >= 60:
        return f"{s // 60} min {s % 60} s"
    return f"{s} s"


class PlainProgress:
    """Progress as plain lines (see the module docstring)."""

    def __init__(
        self,
        total: int,
        initial: int = 0,
        unit: str = "events",
        desc: str = "run",
        file: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.total, self.n, self.unit, self.desc = int(total), int(initial), unit, desc
        self.file = file if file is not None else sys.stderr
        self.clock = clock
        self.started = self._last_line = self._rate_t0 = clock()
        self._rate_n0 = self.n
        self._next_mark = self._mark_after(self.n)
        self.closed = False
        done = f", {initial} already done" if initial else ""
        self._say(f"{desc}: {self.n} of {self.total} {unit} ({self._percent():.0f} %){done}")

    def _mark_after(self, n: int) -> int:
        step = max(1, round(self.total * STEP_FRACTION))
        return (n // step + 1) * step

    def _percent(self) -> float:
        return 100.0 * self.n / self.total if self.total else 100.0

    def _say(self, text: str) -> None:
        print(text, file=self.file, flush=True)
        self._last_line = self.clock()

    def update(self, n: int = 1) -> None:
        self.n += int(n)
        now = self.clock()
        if self.n >= self.total:
            return  # close() says the end
        if self.n >= self._next_mark or now - self._last_line >= STEP_SECONDS:
            self._next_mark = self._mark_after(self.n)
            self._say(self._line(now))

    def _line(self, now: float) -> str:
        text = f"{self.desc}: {self.n} of {self.total} {self.unit} ({self._percent():.0f} %)"
        text += f", {duration_text(now - self.started)}"
        busy, done = now - self._rate_t0, self.n - self._rate_n0
        if busy > 0 and done > 0:
            rate = done / busy
            left = duration_text((self.total - self.n) / rate)
            text += f", {rate:.3g} {self.unit}/s, about {left} left"
        return text

    def unpause(self) -> None:
        """Leave the time since the last call out of the rate (and so out of the time left)."""
        now = self.clock()
        self._rate_t0, self._rate_n0 = now, self.n

    def write(self, text: str) -> None:
        self._say(text)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        took = duration_text(self.clock() - self.started)
        if self.n >= self.total:
            self._say(f"{self.desc}: {self.n} of {self.total} {self.unit} (100 %) in {took}")
        else:
            self._say(f"{self.desc}: stopped at {self.n} of {self.total} {self.unit} after {took}")


class _Silent:
    def update(self, n: int = 1) -> None: ...
    def unpause(self) -> None: ...
    def write(self, text: str) -> None: ...
    def close(self) -> None: ...


def progress_bar(
    total: int,
    initial: int = 0,
    unit: str = "events",
    desc: str = "run",
    show: bool = True,
    file: TextIO | None = None,
) -> Any:
    """A tqdm bar on a terminal, :class:`PlainProgress` lines elsewhere, nothing if not ``show``."""
    file = file if file is not None else sys.stderr
    if not show:
        return _Silent()
    if getattr(file, "isatty", lambda: False)():
        from tqdm import tqdm  # imported here: a worker process shows no bar

        return tqdm(total=total, initial=initial, unit=unit[:2], mininterval=0.5, file=file)
    return PlainProgress(total, initial, unit, desc, file)
