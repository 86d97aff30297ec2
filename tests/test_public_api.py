"""The public face of ``import score4``: the names of ``__all__``, imported lazily, no Geant4."""

from __future__ import annotations

import subprocess
import sys

import pytest

import score4


def test_every_public_name_resolves_and_dir_shows_the_public_face():
    for name in score4.__all__:
        assert getattr(score4, name) is not None, name
    assert dir(score4) == sorted(score4.__all__)
    assert score4.run.__module__ == "score4.runner.engine"
    assert score4.ConfigError is score4.errors.ConfigError


def test_import_score4_is_cheap_and_never_imports_geant4():
    # a fresh interpreter: importing score4 and touching every public name except ``api`` (the
    # library for a Geant4 application) imports neither geant4_pybind nor, before first use, numpy
    code = (
        "import sys, score4\n"
        "assert 'numpy' not in sys.modules, 'numpy imported by import score4'\n"
        "[getattr(score4, n) for n in score4.__all__ if n != 'api']\n"
        "print(sorted(m for m in sys.modules if m.startswith('geant4_pybind')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert out.stdout.strip() == "[]"


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_name"):
        score4.no_such_name  # noqa: B018
