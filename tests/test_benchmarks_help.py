"""Every script of ``benchmarks/`` and ``tools/figures/`` answers ``--help``: its imports work and
its arguments parse, without running. One child process runs all of them in turn (``runpy``, so
score4, numpy and h5py are imported once: about 2 s for all), and each script is its own test
case; a new script is covered as soon as it exists."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = (ROOT / "benchmarks", ROOT / "tools" / "figures")
# imported by the others, not run
HELPERS = {"stamp.py"}
SCRIPTS = sorted(
    str(p.relative_to(ROOT)) for d in FOLDERS for p in d.glob("*.py") if p.name not in HELPERS
)

# Runs in the child: each script as __main__ with ``--help``, its folder first on sys.path as
# when it is run, and what it printed and its exit status, as JSON on the last line.
_CHILD = r"""
import contextlib, io, json, runpy, sys, traceback
results = {}
for path in sys.argv[1:]:
    out, err = io.StringIO(), io.StringIO()
    sys.argv = [path, "--help"]
    sys.path.insert(0, path.rsplit("/", 1)[0])
    code = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            runpy.run_path(path, run_name="__main__")
        except SystemExit as exit:
            code = exit.code
        except BaseException:
            traceback.print_exc()
            code = "raised"
    sys.path.pop(0)
    results[path] = {"code": code, "out": out.getvalue()[:500], "err": err.getvalue()[-2000:]}
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def answers() -> dict[str, dict]:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, *SCRIPTS],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.splitlines()[-1])


def test_every_script_is_found():
    assert len(SCRIPTS) > 30
    assert all((ROOT / "benchmarks" / name).exists() for name in HELPERS)


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda d: d.name)
def test_every_script_is_listed_in_its_folders_readme(folder):
    readme = (folder / "README.md").read_text()
    for path in folder.glob("*.py"):
        assert path.name in readme, f"{path.name} is not in {folder.name}/README.md"


@pytest.mark.parametrize("script", SCRIPTS)
def test_script_answers_help(answers, script):
    got = answers[script]
    assert got["code"] == 0, got["err"]
    assert "usage" in got["out"].lower(), got["out"]
