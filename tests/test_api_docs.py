"""docs/api.md has one mkdocstrings entry per public name of score4.api (the page cannot drift
from the code), each with a docstring."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import score4.api as api

ROOT = Path(__file__).resolve().parents[1]


def test_every_public_name_has_a_docstring_and_an_entry_on_the_page():
    """The page's reference is rendered by mkdocstrings from one directive per public name:
    a name added to score4.api without its entry (or an entry left for a removed name) fails."""
    page = (ROOT / "docs" / "api.md").read_text()
    entries = re.findall(r"^::: score4\.api\.(\w+)$", page, flags=re.MULTILINE)
    assert sorted(entries) == sorted(api.__all__)
    for name in api.__all__:
        assert getattr(api, name).__doc__, name


def test_score4_api_imports_no_geant4():
    """The configuration's process may import score4.api: it must not load Geant4."""
    code = "import sys, score4.api; print('geant4_pybind' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
