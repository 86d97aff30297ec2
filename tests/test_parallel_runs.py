"""Parallel runs under faults, with real (small) Geant4 runs: kill -9 and resume, Ctrl-C, a worker
that crashes, more jobs than chunks, a full disk.

``score4 run`` is started as a subprocess in its own session (process group), so the tests can
signal it and its worker processes the way a user or a batch system does, and check that no
process of the run survives it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.common.limits import MEMORY_ENV
from score4.errors import Score4Error
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.runner.run_plan import config_fingerprint
from score4.sim.worker import CRASH_HOOK

from conftest import config_dict, tmpfs_mount_command

# Each test starts several worker processes: under `make test` (pytest-xdist, -n 2) these run one
# after another on one xdist worker, not side by side with each other (Makefile: test).
pytestmark = pytest.mark.xdist_group("worker-processes")

# 40 chunks of 100 events: a few seconds on 2 cores, so a run can be stopped in the middle.
LONG = {"events": 4000, "seed": 21, "chunk_events": 100}
#: Seconds after which a wait for an event (the run's exit, its workers gone, its parts folder
#: made) fails: a safety bound far above a loaded machine's times. The tests wait for the event,
#: and its time decides nothing.
BOUND_S = 300.0


def quiet(msg: str) -> None:
    pass


@pytest.fixture(scope="module")
def long_run(tmp_path_factory):
    """The LONG configuration (YAML file and object) and its uninterrupted result."""
    folder = tmp_path_factory.mktemp("long")
    data = config_dict(run=LONG)
    path = folder / "long.yaml"
    path.write_text(yaml.safe_dump(data))
    config = parse_config(data)
    reference = read_results(
        run(config, folder / "reference.h5", jobs=2, progress=False, echo=quiet)
    )
    return path, config, reference


def assert_same_events(a, b) -> None:
    """Event ids, primaries and deposits identical: nothing lost, duplicated or changed."""
    assert np.array_equal(a.event_id, b.event_id)
    assert np.array_equal(a.event_id, np.arange(len(a.event_id)))
    assert np.array_equal(a.primary_energy, b.primary_energy)
    assert a.edep.keys() == b.edep.keys()
    for name in a.edep:
        assert np.array_equal(a.edep[name], b.edep[name])
    for field in ("event", "particle", "energy", "position", "direction"):
        assert np.array_equal(getattr(a.primaries, field), getattr(b.primaries, field))


def start_cli(tmp_path: Path, *args: str, env: dict | None = None) -> subprocess.Popen:
    """``score4 run ...`` in a new session; its stderr goes to tmp_path/stderr.txt.

    No progress bar (stderr is a file: plain progress lines), so the notices stay readable.
    ``env``: variables added to the environment.
    """
    with open(tmp_path / "stderr.txt", "w") as err:
        return subprocess.Popen(
            [sys.executable, "-m", "score4.cli.main", "run", *args],
            stdout=subprocess.DEVNULL,
            stderr=err,
            start_new_session=True,
            env={**os.environ, **(env or {})},
        )


def wait_for_chunks(
    parts: Path, n: int, proc: subprocess.Popen, timeout: float = 300
) -> list[Path]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = sorted(parts.glob("chunk-*.h5"))
        if len(found) >= n:
            return found
        assert proc.poll() is None, "the run ended before it could be interrupted"
        time.sleep(0.02)
    raise AssertionError(f"no {n} finished chunks in {parts} after {timeout} s")


def session_processes(sid: int) -> list[int]:
    """Live (non-zombie) processes of session ``sid``, from /proc."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            if os.getsid(int(entry.name)) == sid and stat.rsplit(")", 1)[1].split()[0] != "Z":
                pids.append(int(entry.name))
        except (OSError, IndexError):
            pass
    return pids


def wait_no_processes(sid: int, timeout: float = BOUND_S) -> None:
    deadline = time.monotonic() + timeout
    while (left := session_processes(sid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not left, f"processes of the run still alive: {left}"


def process_cpu(pid: int) -> float:
    """CPU seconds (user + system) process ``pid`` has used itself, from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def cpu_at_exit(proc: subprocess.Popen, timeout: float = BOUND_S) -> float:
    """CPU seconds ``proc`` used in all, read once it has exited (a zombie) and before it is
    reaped (``proc.wait()`` after this gives its status)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        stat = Path(f"/proc/{proc.pid}/stat").read_text()
        if stat.rsplit(")", 1)[1].split()[0] == "Z":
            return process_cpu(proc.pid)
        time.sleep(0.02)
    raise AssertionError(f"the run did not end within {timeout} s")


def check_chunk_files(parts: Path, config) -> set[int]:
    """Indices of the finished chunk files, each checked complete and belonging to this run."""
    fingerprint = config_fingerprint(config, config.run.seed)
    size = config.run.chunk_events
    done = set()
    for path in parts.glob("chunk-*.h5"):
        index = int(path.stem.split("-")[1])
        with h5py.File(path, "r") as f:
            assert f.attrs["fingerprint"] == fingerprint
            assert f.attrs["first_event"] == index * size
            assert np.array_equal(f["events/event_id"][()], index * size + np.arange(size))
            assert len(f["events/edep/crystal"]) == size
        done.add(index)
    return done


needs_proc = pytest.mark.skipif(
    not Path("/proc/self/stat").exists(), reason="process checks read /proc (Linux)"
)


@pytest.mark.slow
@needs_proc
def test_kill_9_then_resume_gives_the_uninterrupted_result(tmp_path: Path, long_run):
    config_file, config, reference = long_run
    out = tmp_path / "killed.h5"
    parts = tmp_path / "killed.h5.parts"
    proc = start_cli(tmp_path, str(config_file), "--out", str(out), "--jobs", "2")
    wait_for_chunks(parts, 2, proc)
    os.killpg(proc.pid, signal.SIGKILL)  # the parent and its workers, at once
    proc.wait(timeout=BOUND_S)
    wait_no_processes(proc.pid)
    assert not out.exists()
    done = check_chunk_files(parts, config)
    assert 2 <= len(done) < 40
    # Damage on top of the kill: a truncated copy of a finished chunk under the name of a missing
    # one, and a stray temporary file. Neither may count as finished.
    missing = min(set(range(40)) - done)
    good = parts / f"chunk-{min(done):06d}.h5"
    (parts / f"chunk-{missing:06d}.h5").write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    (parts / f".chunk-{missing + 1:06d}.h5.x1y2z3.partial").write_bytes(b"half")

    proc = start_cli(tmp_path, str(config_file), "--out", str(out), "--jobs", "2", "--resume")
    assert proc.wait(timeout=600) == 0, (tmp_path / "stderr.txt").read_text()
    said = (tmp_path / "stderr.txt").read_text()
    assert f"resume: {len(done)} of 40 chunks already finished" in said
    assert f"chunk files {missing} in {parts} are damaged or incomplete; they are run again" in said
    assert not parts.exists()
    result = read_results(out)
    assert_same_events(result, reference)
    assert result.run["resumed_chunks"] == len(done)


@pytest.mark.slow
@needs_proc
def test_ctrl_c_stops_workers_keeps_chunks_and_says_how_to_resume(tmp_path: Path, long_run):
    config_file, config, reference = long_run
    out = tmp_path / "stopped.h5"
    parts = tmp_path / "stopped.h5.parts"
    proc = start_cli(tmp_path, str(config_file), "--out", str(out), "--jobs", "2")
    wait_for_chunks(parts, 1, proc)
    os.kill(proc.pid, signal.SIGINT)  # the parent only: it must stop its workers itself
    assert proc.wait(timeout=BOUND_S) == 130
    wait_no_processes(proc.pid)  # no orphaned workers
    said = (tmp_path / "stderr.txt").read_text()
    done = check_chunk_files(parts, config)
    assert 1 <= len(done) < 40
    assert f"run interrupted: {len(done)} of 40 chunks are finished and kept in {parts}" in said
    assert "--resume" in said
    assert "Traceback" not in said
    result = read_results(run(config, out, jobs=2, resume=True, progress=False, echo=quiet))
    assert_same_events(result, reference)


@needs_proc
def test_ctrl_c_stops_a_huge_run_at_once(tmp_path: Path):
    # 10^11 events: nothing may be built per event or per chunk in the main process (a list of
    # 10^7 chunks took > 40 s and 2 GB before, and the Ctrl-C handler looked at every chunk's file).
    config_file = tmp_path / "huge.yaml"
    config_file.write_text(yaml.safe_dump(config_dict()))
    parts = tmp_path / "huge.h5.parts"
    # (this machine could not merge 10^11 events: score4 would refuse the run at once, so the
    # test lets it plan with 10 PB of memory)
    proc = start_cli(
        tmp_path,
        str(config_file),
        "--out",
        str(tmp_path / "huge.h5"),
        "--events",
        "1e11",
        env={MEMORY_ENV: "1e16"},
    )
    deadline = time.monotonic() + BOUND_S
    while not parts.exists() and time.monotonic() < deadline:  # the workers are being started
        assert proc.poll() is None, (tmp_path / "stderr.txt").read_text()
        time.sleep(0.05)
    assert parts.exists()
    before = process_cpu(proc.pid)
    os.kill(proc.pid, signal.SIGINT)
    # "at once" as the CPU the run's process spends after the Ctrl-C, not as a wall time (that
    # depends on the machine's load): 10^7 chunks built or looked at took > 40 s
    assert cpu_at_exit(proc) - before < 5.0
    assert proc.wait() == 130
    wait_no_processes(proc.pid)
    said = (tmp_path / "stderr.txt").read_text()
    assert "run interrupted before any chunk finished; nothing kept" in said, said
    assert not parts.exists()
    assert not (tmp_path / "huge.h5").exists()


@pytest.mark.slow
@needs_proc
def test_sigterm_stops_like_ctrl_c(tmp_path: Path, long_run):
    config_file, config, _ = long_run
    parts = tmp_path / "t.h5.parts"
    proc = start_cli(tmp_path, str(config_file), "--out", str(tmp_path / "t.h5"), "--jobs", "2")
    wait_for_chunks(parts, 1, proc)
    os.kill(proc.pid, signal.SIGTERM)  # what a batch system sends at its time limit
    assert proc.wait(timeout=BOUND_S) == 130
    wait_no_processes(proc.pid)
    assert "run interrupted" in (tmp_path / "stderr.txt").read_text()
    assert check_chunk_files(parts, config)


def test_more_jobs_than_chunks_says_so_and_uses_fewer(tmp_path: Path, make_config):
    said = []
    config = make_config(run={"events": 3, "seed": 4})
    res = read_results(run(config, tmp_path / "j.h5", jobs=5, progress=False, echo=said.append))
    assert said[0] == (
        "notice: --jobs 5 but only 3 chunk(s) to run (the run has 3 event(s)); using 3 worker(s)"
    )
    assert res.run["jobs"] == 3
    assert res.n_events == 3
    assert res.run["n_chunks"] == 3


def test_small_runs_use_every_requested_worker_and_say_nothing(tmp_path: Path, make_config):
    # make demo: 5000 events on 2 processes are 2 chunks (3000 + 2000 events), one per worker
    said = []
    config = make_config(
        source={"particle": "alpha", "energy": "1 MeV"}, run={"events": 5000, "seed": 4}
    )
    res = read_results(run(config, tmp_path / "d.h5", jobs=2, progress=False, echo=said.append))
    assert res.run["jobs"] == 2
    assert res.run["n_chunks"] == 2
    assert res.run["chunk_events"] == 3000
    assert not [m for m in said if m.startswith("notice")], said
    # (that the chunking does not change the events: test_run_engine, first events of a longer run)


def test_a_crashing_worker_fails_its_chunk_only_and_resume_retries_it(
    tmp_path: Path, make_config, monkeypatch, capsys
):
    data = config_dict(run={"events": 500, "seed": 8, "chunk_events": 100})
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(data))
    config = parse_config(data)
    reference = read_results(run(config, tmp_path / "ref.h5", jobs=2, progress=False, echo=quiet))
    out, parts = tmp_path / "crash.h5", tmp_path / "crash.h5.parts"

    monkeypatch.setenv(CRASH_HOOK, "2")  # the process running chunk 2 dies (os._exit(70))
    status = main(["run", str(config_file), "--out", str(out), "--jobs", "2", "--quiet"])
    err = capsys.readouterr().err
    assert status == 2
    assert "chunk 2 failed (WorkerDied: worker process" in err
    assert "died, exit code 70)" in err
    assert f"4 of 5 chunks are finished and kept in {parts}" in err
    assert "--resume to retry the failed and missing chunks" in err
    assert check_chunk_files(parts, config) == {0, 1, 3, 4}  # a new worker ran the chunks after it
    assert not out.exists()

    monkeypatch.delenv(CRASH_HOOK)
    assert main(["run", str(config_file), "--out", str(out), "--jobs", "2", "--resume"]) == 0
    assert "resume: 4 of 5 chunks already finished" in capsys.readouterr().err
    assert_same_events(read_results(out), reference)


def test_repeated_crashes_stop_the_run(tmp_path: Path, make_config, monkeypatch):
    config = make_config(run={"events": 500, "seed": 8, "chunk_events": 100})
    monkeypatch.setenv(CRASH_HOOK, "0,1,2")
    with pytest.raises(Score4Error) as info:
        run(config, tmp_path / "x.h5", jobs=1, progress=False, echo=quiet)
    text = str(info.value)
    assert text.startswith("run: chunk 0 failed (WorkerDied")
    assert "chunk 1 failed" in text
    assert "chunk 2 failed" in text
    assert "stopped after 3 failed chunks; 2 chunk(s) not run: 3-4" in text
    assert (
        f"Geant4's output: {tmp_path / 'x.geant4.log'}" in text
    )  # nothing finished: no parts kept, the log is
    assert not (tmp_path / "x.h5.parts").exists()
    assert not (tmp_path / "x.h5").exists()


@pytest.mark.slow
@pytest.mark.deep  # three runs of 3600 events; test_output's full-disk checks stay in make test
def test_full_disk_stops_with_a_clear_error_and_keeps_finished_chunks(tmp_path: Path):
    # A real full disk: the run writes into a 640 kB tmpfs mounted in a private mount namespace.
    mnt = tmp_path / "small_disk"
    mnt.mkdir()
    unshare = tmpfs_mount_command(mnt)
    if unshare is None:
        pytest.skip("cannot mount a tmpfs in a private mount namespace here (unshare -m / -rm)")
    data = config_dict(run={"events": 3600, "seed": 5, "chunk_events": 300})
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(data))
    config = parse_config(data)
    script = (
        f"mount -t tmpfs -o size=640k tmpfs {mnt} || exit 99; {sys.executable} -m score4.cli.main "
        f"run {config_file} --out {mnt}/x.h5 --jobs 2 --quiet 2> {tmp_path}/err.txt; echo $? > "
        f"{tmp_path}/rc.txt; df -k {mnt} > {tmp_path}/df.txt; cp -a {mnt}/x.h5.parts "
        f"{tmp_path}/x.h5.parts"
    )
    subprocess.run([*unshare, "sh", "-c", script], check=True, timeout=600)
    err = (tmp_path / "err.txt").read_text()
    assert (tmp_path / "rc.txt").read_text().strip() == "2", err
    assert "score4: error: run: chunk" in err
    assert "failed: cannot write" in err
    assert "the disk is full" in err
    assert "--resume" in err
    assert "Traceback" not in err
    parts = tmp_path / "x.h5.parts"
    done = check_chunk_files(parts, config)
    assert 1 <= len(done) < 12
    # with room again, a resume finishes the run and gives what an uninterrupted run gives
    resumed = read_results(
        run(config, tmp_path / "x.h5", jobs=2, resume=True, progress=False, echo=quiet)
    )
    reference = read_results(run(config, tmp_path / "ref.h5", jobs=2, progress=False, echo=quiet))
    assert_same_events(resumed, reference)
