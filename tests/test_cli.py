"""The score4 command line: exit codes, one-line errors, JSON summary."""

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

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
    assert out.startswith("score4 ")
    assert "geant4_pybind 0.1" in out


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "does not exist"),
        ("targets: [", "not valid YAML"),
        ("targets: []\nsource: {energy: 5 MeV, surface: {volume: x}}\n", "targets"),
        (
            (
                "{targets: [{name: c, size: [1 cm, 1 cm, 1 cm]}], source: {energy: '5', surface: "
                "{volume: c}}}"
            ),
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
    assert err.startswith("score4: error: ")
    assert message in err
    assert "\n" not in err
    assert not (tmp_path / "o.h5").exists()


def test_output_folder_missing_exits_2(tmp_path: Path, capsys):
    code = main(
        ["run", str(ROOT / "examples" / "flat_alpha.yaml"), "--out", str(tmp_path / "no" / "o.h5")]
    )
    assert code == 2
    assert "does not exist" in capsys.readouterr().err


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
    assert done.stderr == ""  # -q: errors only, not even the lite-mode warning
    again = run_cli(
        "run", ROOT / "examples" / "flat_alpha.yaml", "--events", 200, "--out", out, "-q"
    )
    assert again.returncode == 2
    assert "already exists; use --overwrite" in again.stderr
    summary = run_cli("summary", out, "--json")
    assert summary.returncode == 0, summary.stderr
    s = json.loads(summary.stdout)
    assert s["n_events"] == 200
    assert s["seed"] == 4
    assert s["physics_mode"] == "lite"
    (vol,) = s["volumes"]
    assert set(vol) == {
        "name",
        "mean_edep_MeV",
        "n_nonzero",
        "histogram",
        "material",
        "mass_kg",
        "above_threshold",
        "alone_above_threshold",
        "rate_per_event",
        "rate_per_event_per_kg",
    }
    assert vol["material"] == "G4_Si"
    assert vol["mass_kg"] == pytest.approx(9 * 2.33e-3, rel=1e-3)  # 9 cm3 of silicon (NIST)
    assert s["multiplicity"]["events"]["1"] == vol["above_threshold"]
    assert len(vol["histogram"]["edges_MeV"]) == 101
    assert len(vol["histogram"]["counts"]) == 100
    assert sum(vol["histogram"]["counts"]) == 200
    text = run_cli("summary", out)
    assert "energy check  0 events deposit more than" in text.stdout


def test_summary_of_missing_file_exits_2(tmp_path: Path, capsys):
    assert main(["summary", str(tmp_path / "none.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_warnings_are_one_line_each_once_and_quiet_silences_them(tmp_path: Path):
    # lite physics (run by the engine) and density normalisation (a rough face's patch map)
    data = yaml.safe_load((ROOT / "examples" / "flat_alpha.yaml").read_text())
    data["surfaces"] = {
        "s": {"kind": "spikes", "nx": 2, "ny": 2, "width": "5 um", "height": "2 um"}
    }
    data["targets"][0]["rough"] = [
        {
            "variants": [{"surface": "s", "density": 1}, {"surface": "s", "density": 1}],
            "fill": "random",
        }
    ]
    data["targets"][0]["size"] = ["10 um", "10 um", "1 cm"]
    config = tmp_path / "w.yaml"
    config.write_text(yaml.safe_dump(data))
    loud = run_cli("run", config, "--events", 5, "--out", tmp_path / "a.h5")
    assert loud.returncode == 0, loud.stderr
    warned = [line for line in loud.stderr.splitlines() if "warning:" in line]
    assert len(warned) == 2, loud.stderr
    assert all(line.startswith("score4: warning: ") for line in warned)
    assert sum("lite mode" in line for line in warned) == 1
    assert (
        sum("densities: sum is 2, not 1; normalised to [0.5, 0.5]" in line for line in warned) == 1
    )
    assert ".py" not in loud.stderr
    assert "UserWarning" not in loud.stderr
    quiet = run_cli("run", config, "--events", 5, "--out", tmp_path / "b.h5", "-q")
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stderr == ""


def test_errors_found_after_validation_name_the_config_file(tmp_path: Path, capsys):
    data = yaml.safe_load((ROOT / "examples" / "flat_alpha.yaml").read_text())
    data["targets"][0]["material"] = "G4_SILICON"
    config = tmp_path / "m.yaml"
    config.write_text(yaml.safe_dump(data))
    assert main(["run", str(config), "--events", "5", "--out", str(tmp_path / "m.h5"), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(
        f"score4: error: {config}: targets.0.material: unknown material 'G4_SILICON'; "
        "closest NIST names: G4_Si, "
    ), err
    assert "\n" not in err
    assert not list(tmp_path.glob("m.h5*"))


def test_events_take_whole_numbers_also_in_exponent_form(tmp_path: Path, capsys):
    flat = str(ROOT / "examples" / "flat_alpha.yaml")
    assert main(["run", flat, "--events", "2.5", "--out", str(tmp_path / "x.h5")]) == 2
    assert "'2.5' is not a whole number of events" in capsys.readouterr().err
    assert main(["run", flat, "--events", "0", "--out", str(tmp_path / "x.h5")]) == 2
    assert "need at least 1 event" in capsys.readouterr().err
    assert main(["vertices", flat, "--n", "2e3", "--out", str(tmp_path / "v.h5")]) == 0
    assert "2000 events" in capsys.readouterr().out


FLAT = ROOT / "examples" / "flat_alpha.yaml"
PYRAMIDS = ROOT / "examples" / "surfaces" / "pyramids.yaml"
MACRO = ROOT / "tests" / "data" / "macros" / "paper_example.mac"


@pytest.fixture(scope="module")
def small_results(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("results") / "r.h5"
    assert main(["run", str(FLAT), "--events", "5", "--out", str(out), "-q"]) == 0
    return out


# Every command that writes a file: arguments ({out}: the output), the option naming it, file name
WRITERS = [
    (["run", FLAT, "--events", "5", "-q", "--out", "{out}"], "--out", "r.h5"),
    (["vertices", FLAT, "--n", "5", "--out", "{out}"], "--out", "v.h5"),
    (["plot", "{results}", "--out", "{out}"], "--out", "spectra.png"),
    (["export", "{results}", "--csv", "{out}"], "--csv", "h.csv"),
    (["export", "{results}", "--events-csv", "{out}"], "--events-csv", "e.csv"),
    (["export", "{results}", "--root", "{out}"], "--root", "r.root"),
    (["surface", "generate", PYRAMIDS, "--out", "{out}"], "--out", "p.s4s.h5"),
    (["surface", "show", PYRAMIDS, "--png", "{out}"], "--png", "p.png"),
    (["surface", "export", PYRAMIDS, "--stl", "{out}"], "--stl", "p.stl"),
    (["range", "alpha", "5 MeV", "G4_Si", "-n", "5", "-q", "--png", "{out}"], "--png", "d.png"),
    (["import-macro", MACRO, "--out", "{out}"], "--out", "c.yaml"),
]


@pytest.mark.parametrize(
    ("args", "option", "name"),
    WRITERS,
    ids=[" ".join(a for a in w[0][:2] if isinstance(a, str) and "{" not in a) for w in WRITERS],
)
def test_commands_replace_existing_files_only_with_overwrite(
    tmp_path: Path, capsys, small_results, args, option, name
):
    out = tmp_path / name
    out.write_bytes(b"keep me")
    argv = [str(a).format(out=out, results=small_results) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err
    said = f"score4: error: {option}: '{out}' already exists; use --overwrite to replace it\n"
    assert err == said
    assert out.read_bytes() == b"keep me"
    assert [p.name for p in tmp_path.iterdir()] == [name]  # nothing else written
    if args[0] == "range":  # Geant4 runs in this process: a fresh one (pytest never imports it)
        done = run_cli(*argv, "--overwrite")
        assert done.returncode == 0, done.stderr
    else:
        assert main([*argv, "--overwrite"]) == 0, capsys.readouterr().err
    assert out.read_bytes()[:7] != b"keep me"


def test_make_demo_runs_twice_in_a_row(tmp_path: Path, monkeypatch, capsys):
    # The recipe of `make demo`, with 20 events instead of 5000, run twice in one folder.
    recipe = (ROOT / "Makefile").read_text().split("\ndemo:", 1)[1].split("\n\n", 1)[0]
    lines = [line.strip() for line in recipe.splitlines()[1:] if line.startswith("\t")]
    assert any(" plot " in line for line in lines)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(tmp_path)
    for _ in range(2):
        for line in lines:
            words = shlex.split(line.replace("$(BIN)/", ""))
            if words[0] == "mkdir":
                Path(words[-1]).mkdir(parents=True, exist_ok=True)
                continue
            assert words[0] == "score4", line
            args = ["20" if w == "5000" else w for w in words[1:]]
            assert main(["-q", *args]) == 0, capsys.readouterr().err
    assert Path("out/demo/spectra.png").stat().st_size > 0


def _density_warning_config(tmp_path: Path) -> Path:
    """flat_alpha.yaml with a rough face whose variant densities are normalised (a warning)."""
    data = yaml.safe_load(FLAT.read_text())
    spikes = {"kind": "spikes", "nx": 2, "ny": 2, "width": "5 um", "height": "2 um"}
    data["surfaces"] = {"s": spikes}
    data["targets"][0]["rough"] = [
        {"variants": [{"surface": "s", "density": 1}, {"surface": "s", "density": 1}]}
    ]
    data["targets"][0]["size"] = ["20 um", "10 um", "1 cm"]  # two patches: one of each
    config = tmp_path / "w.yaml"
    config.write_text(yaml.safe_dump(data))
    return config


def test_group_quiet_silences_progress_and_warnings_of_every_command(tmp_path: Path, capsys):
    config = _density_warning_config(tmp_path)
    portal = ROOT / "tests" / "data" / "macros" / "portal_example.mac"
    commands = {
        "vertices": (["vertices", config, "--n", "5", "--out", "{tmp}/v{i}.h5"], "normalised"),
        "import-macro": (["import-macro", portal, "--out", "{tmp}/c{i}.yaml"], "not converted"),
        "run": (["run", config, "--events", "5", "--out", "{tmp}/r{i}.h5"], "lite mode"),
    }
    for name, (args, said) in commands.items():
        for i, quiet in enumerate(([], ["-q"])):
            argv = [*quiet, *(str(a).format(tmp=tmp_path, i=i) for a in args)]
            assert main(argv) == 0, (name, capsys.readouterr().err)
            captured = capsys.readouterr()
            if quiet:
                assert captured.err == "", (name, captured.err)
            else:
                assert said in captured.err, (name, captured.err)
            assert "wrote " in captured.out, name  # results still print
    assert main(["-q", "run", str(FLAT), "--events", "0"]) == 2  # errors still print
    assert capsys.readouterr().err.startswith("score4: error: run: --events: ")
    # range runs Geant4 in its own process: in a fresh one (pytest never imports Geant4)
    args = ["range", "alpha", "5 MeV", "G4_Si", "-n", "5"]
    loud, quiet = run_cli(*args, cwd=tmp_path), run_cli("-q", *args, cwd=tmp_path)
    assert (loud.returncode, quiet.returncode) == (0, 0), loud.stderr + quiet.stderr
    assert loud.stderr.startswith("score4: 5 alpha ions of 5000 keV into G4_Si ...")
    assert quiet.stderr == ""
    assert quiet.stdout == loud.stdout


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            ["run", "--evnts", "3", "x.yaml"],
            "run: no such option --evnts (did you mean --events?); try 'score4 run --help'",
        ),
        (["run"], "run: missing argument CONFIG.yaml; try 'score4 run --help'"),
        (["plt"], "no such command 'plt' (did you mean plot?); try 'score4 --help'"),
        (
            ["surface", "shw"],
            "surface: no such command 'shw' (did you mean show?); try 'score4 surface --help'",
        ),
        (
            ["run", "x.yaml", "--jobs", "0"],
            "run: --jobs: must be >= 1, got 0; try 'score4 run --help'",
        ),
        (["plot", "a.h5", "--out"], "plot: --out: needs a value; try 'score4 plot --help'"),
        (["-q", "plot", "a.h5", "--out"], "plot: --out: needs a value; try 'score4 plot --help'"),
        (
            ["surface", "show", "f.yaml", "--png", "f.png", "--dpi", "5"],
            "surface show: --dpi: must be in [20, 1200], got 5; try 'score4 surface show --help'",
        ),
        (
            ["data", "install", "--mode", "xx"],
            (
                "data install: --mode: must be one of 'full', 'decay', got 'xx'; "
                "try 'score4 data install --help'"
            ),
        ),
        (
            ["run", "x.yaml", "y.yaml"],
            "run: unexpected extra argument(s): y.yaml; try 'score4 run --help'",
        ),
        (
            ["run", "x.yaml", "--events", "2.5"],
            "run: --events: '2.5' is not a whole number of events; try 'score4 run --help'",
        ),
    ],
)
def test_usage_errors_are_one_line(argv, line, capsys):
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err == f"score4: error: {line}\n"
    assert captured.out == ""


def test_help_still_shows_usage(capsys):
    assert main(["run", "--help"]) == 0
    assert capsys.readouterr().out.startswith("Usage: score4 run [OPTIONS] CONFIG.yaml")
    assert main(["-h"]) == 0
    assert "-q, --quiet" in capsys.readouterr().out
    assert main(["surface"]) == 2  # a group alone shows its help, as click does
    assert "Commands:" in capsys.readouterr().err


def test_python_dash_m_score4_is_the_command():
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    done = subprocess.run(
        [sys.executable, "-m", "score4", "--version"], capture_output=True, text=True, env=env
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("score4 ")
