"""Every bad input of issues 20 and 26 ("Why" lists) ends in one line and exit status 2, before
any Geant4 work, with no output written and no input changed, or is now handled as a user
expects (tests/helpers/bad_inputs.py holds the cases and, run as a script, classifies them as a user
meets them); and a GDML export to a full disk keeps the old file."""

from __future__ import annotations

import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from score4.cli.main import main

from conftest import tmpfs_mount_command
from helpers.bad_inputs import CASES, Case, digest, gdml_config, gdml_world


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


def _file_size_limit(nbytes: int):
    """preexec_fn: files of at most ``nbytes`` (a write past it fails, as on a full disk)."""

    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (nbytes, nbytes))

    return limit


def test_geometry_export_to_a_full_disk_is_an_error_and_keeps_the_old_file(tmp_path):
    """Geant4's GDML writer does not report a failed write: the export checks that the file
    it wrote is complete before it replaces anything (issue 26: it said 'wrote r.gdml' for a
    truncated file). A full disk is simulated by a file-size limit (RLIMIT_FSIZE) of 500 B, below
    the ~1 kB of this world's GDML (the export keeps the user's file and adds no layer)."""
    gdml_world(tmp_path / "w.gdml")
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(gdml_config()))
    assert main(["geometry", "list", str(tmp_path / "c.yaml")]) == 0  # its model cached
    (tmp_path / "out.gdml").write_text("old\n")
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "score4",
            "geometry",
            "export",
            "c.yaml",
            "--gdml",
            "out.gdml",
            "--overwrite",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=_file_size_limit(500),
        check=False,
    )
    assert done.returncode == 2, done.stderr[-2000:]
    # the user's file is copied by Python, score4's additions written by Geant4's writer: the
    # limit cuts whichever is written first
    assert done.stderr.startswith("score4: error: "), done.stderr
    assert "incomplete" in done.stderr
    assert "Traceback" not in done.stderr
    assert "wrote" not in done.stdout
    assert (tmp_path / "out.gdml").read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml", "mat.xml", "out.gdml", "w.gdml"]


def test_a_gdml_files_own_overlaps_are_read_once_per_content(tmp_path, monkeypatch, capsys):
    """The overlap check runs with the volume model, in the one Geant4 read of a GDML file that
    its cache (keyed by content) keeps: a second command reads no GDML; a changed file is
    read (and checked) again."""
    from score4.world import gdml_files

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    gdml_files._MODELS.clear()
    reads = []
    real = gdml_files._read_in_subprocess
    monkeypatch.setattr(gdml_files, "_read_in_subprocess", lambda *a: reads.append(a) or real(*a))
    gdml_world(tmp_path / "w.gdml", plate_z=-8.0)
    for _ in range(2):
        assert main(["geometry", "list", str(tmp_path / "w.gdml")]) == 0
        gdml_files._MODELS.clear()  # as a new process: only the disk cache is left
    out = capsys.readouterr().out
    assert len(reads) == 1
    assert out.count("overlap: crystal_pv and plate_pv by 4 mm") == 2
    gdml_world(tmp_path / "w.gdml", plate_z=-13.0)  # touching, not overlapping
    assert main(["geometry", "list", str(tmp_path / "w.gdml")]) == 0
    assert len(reads) == 2
    assert "overlap:" not in capsys.readouterr().out
    gdml_files._MODELS.clear()


@pytest.mark.deep
def test_geometry_export_to_a_real_full_disk_keeps_the_old_file(tmp_path):
    """As above on a real full disk (ENOSPC): an 8 kB tmpfs in a private mount namespace whose
    two pages hold the old file and a filler."""
    mnt = tmp_path / "small_disk"
    mnt.mkdir()
    unshare = tmpfs_mount_command(mnt)
    if unshare is None:
        pytest.skip("cannot mount a tmpfs in a private mount namespace here (unshare -m / -rm)")
    gdml_world(tmp_path / "w.gdml")
    (tmp_path / "c.yaml").write_text(yaml.safe_dump(gdml_config()))
    assert main(["geometry", "list", str(tmp_path / "c.yaml")]) == 0  # its model cached
    export = f"{sys.executable} -m score4 geometry export c.yaml --gdml {mnt}/out.gdml --overwrite"
    script = (
        f"mount -t tmpfs -o size=8k tmpfs {mnt} || exit 99; echo old > {mnt}/out.gdml; "
        f"head -c 2000 /dev/zero > {mnt}/filler; cd {tmp_path}; {export} 2> err.txt; "
        f"echo $? > rc.txt; cp {mnt}/out.gdml after.gdml; ls -a {mnt} > ls.txt"
    )
    subprocess.run([*unshare, "sh", "-c", script], check=True, timeout=300)
    err = (tmp_path / "err.txt").read_text()
    assert (tmp_path / "rc.txt").read_text().strip() == "2", err
    assert err.startswith(f"score4: error: cannot write {mnt}/out.gdml: "), err
    assert "Traceback" not in err
    assert (tmp_path / "after.gdml").read_text() == "old\n"
    assert (tmp_path / "ls.txt").read_text().split() == [".", "..", "filler", "out.gdml"]
