"""The score4 command line: exit codes, one-line errors, JSON summary."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from score4.cli.main import main

from conftest import ROOT


def run_cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "score4.cli.main", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
    )


def test_version(capsys):
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("score4 ") and "geant4_pybind 0.1" in out


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "does not exist"),
        ("targets: [", "not valid YAML"),
        ("targets: []\nsource: {energy: 5 MeV, surface: {volume: x}}\n", "targets"),
        (
            "{targets: [{name: c, size: [1 cm, 1 cm, 1 cm]}], source: {energy: '5', surface: {volume: c}}}",
            "has no unit",
        ),
    ],
)
def test_bad_config_exits_2_with_one_line(tmp_path: Path, capsys, content, message):
    path = tmp_path / "c.yaml"
    if content is not None:
        path.write_text(content)
    assert main(["run", str(path), "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("score4: error: ") and message in err and "\n" not in err
    assert not (tmp_path / "o.h5").exists()


def test_output_folder_missing_exits_2(tmp_path: Path, capsys):
    code = main(
        ["run", str(ROOT / "examples" / "flat_alpha.yaml"), "--out", str(tmp_path / "no" / "o.h5")]
    )
    assert code == 2 and "does not exist" in capsys.readouterr().err


def test_run_then_summary_json(tmp_path: Path):
    out = tmp_path / "demo.h5"
    done = run_cli(
        "run",
        ROOT / "examples" / "flat_alpha.yaml",
        "--events",
        200,
        "--seed",
        4,
        "--out",
        out,
        "-q",
    )
    assert done.returncode == 0, done.stderr
    assert "lite mode" in done.stderr  # the one warning about missing data
    again = run_cli(
        "run", ROOT / "examples" / "flat_alpha.yaml", "--events", 200, "--out", out, "-q"
    )
    assert again.returncode == 2 and "already exists; use --overwrite" in again.stderr
    summary = run_cli("summary", out, "--json")
    assert summary.returncode == 0, summary.stderr
    s = json.loads(summary.stdout)
    assert s["n_events"] == 200 and s["seed"] == 4 and s["physics_mode"] == "lite"
    (vol,) = s["volumes"]
    assert set(vol) == {"name", "mean_edep_MeV", "n_nonzero", "histogram"}
    assert len(vol["histogram"]["edges_MeV"]) == 101 and len(vol["histogram"]["counts"]) == 100
    assert sum(vol["histogram"]["counts"]) == 200
    text = run_cli("summary", out)
    assert "energy check  0 events deposit more than" in text.stdout


def test_summary_of_missing_file_exits_2(tmp_path: Path, capsys):
    assert main(["summary", str(tmp_path / "none.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err
