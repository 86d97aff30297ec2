"""Every bad input of issue 20's "Why" list ends in one line and exit status 2, before any
Geant4 work, with no output written and no input changed (tests/_bad_inputs.py holds the cases
and, run as a script, classifies them as a user meets them)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from _bad_inputs import CASES, Case, digest

from score4.cli.main import main


def _run(case: Case, folder: Path, capsys) -> tuple[int, str]:
    if case.subprocess:  # Geant4 in the command, or a hang when it fails: its own process
        p = subprocess.run(
            [sys.executable, "-m", "score4", *case.argv],
            cwd=folder,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        return p.returncode, p.stderr
    code = main(list(case.argv))
    return code, capsys.readouterr().err


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_one_line_and_exit_2(case: Case, tmp_path: Path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    case.write(tmp_path)
    before = digest(tmp_path)
    code, err = _run(case, tmp_path, capsys)
    assert "Traceback" not in err
    after = digest(tmp_path)
    for name, h in before.items():  # no input changed (nor removed)
        assert after.get(name) == h, f"{name} changed"
    if not case.expect:  # an input that is fine now (a count written 2e2)
        assert code == 0, err
        return
    lines = [line for line in err.splitlines() if not line.startswith("score4: warning:")]
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith("score4: error: ")
    assert case.expect in lines[0], lines[0]
    assert "worker" not in lines[0]  # refused before any Geant4 worker started
    assert set(after) == set(before), "an output was written"


def test_the_table_covers_every_class_of_the_issue():
    classes = {c.cls for c in CASES}
    assert classes == {"crash", "traceback", "silent", "footgun", "other"}
    assert len({c.id for c in CASES}) == len(CASES)
