"""docs/api.md is what tools/make_api_docs.py makes from score4.api's docstrings (the page
cannot drift from the code), and every public name of score4.api is documented."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import score4.api as api

ROOT = Path(__file__).resolve().parents[1]


def test_api_page_is_current():
    proc = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "make_api_docs.py"), "--check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_every_public_name_has_a_docstring_on_the_page():
    page = (ROOT / "docs" / "api.md").read_text()
    for name in api.__all__:
        obj = getattr(api, name)
        assert obj.__doc__, name
        assert f"### `{name}(" in page or f"### `class {name}(" in page, name


def test_score4_api_imports_no_geant4():
    """The configuration's process may import score4.api: it must not load Geant4."""
    code = "import sys, score4.api; print('geant4_pybind' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
