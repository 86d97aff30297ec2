#!/usr/bin/env python3
# /// script
# dependencies = ["nox>=2025.10.14"]
# ///
"""nox sessions, for those who use nox: each one runs the Makefile target of the same name.

The Makefile is score4's task runner (``make test``, ``make lint``, ``make demo``): it creates
``.venv`` and installs score4 with what the tests and the linters need. These sessions add no
environment of their own, so ``nox`` and ``make`` always run the same commands.
"""

from __future__ import annotations

import nox

nox.needs_version = ">=2025.10.14"
nox.options.default_venv_backend = "none"  # the Makefile owns .venv


@nox.session(default=True)
def lint(session: nox.Session) -> None:
    """ruff check, ruff format --check, mypy and lint-imports (``make lint``)."""
    session.run("make", "lint", external=True)


@nox.session(default=True)
def tests(session: nox.Session) -> None:
    """The test suite (``make test``); extra arguments go to pytest."""
    session.run("make", "test", f"PYTEST_ARGS={' '.join(session.posargs)}", external=True)


@nox.session(default=False)
def demo(session: nox.Session) -> None:
    """The paper's flat-vs-rough alpha example, plotted into out/demo (``make demo``)."""
    session.run("make", "demo", external=True)


@nox.session(default=False)
def docs(session: nox.Session) -> None:
    """The documentation site, built offline and strictly into site/ (``make docs``)."""
    session.run("make", "docs", external=True)


if __name__ == "__main__":
    nox.main()
