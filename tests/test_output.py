"""Writing HDF5 files: atomic, and a failed write (full disk, file-size limit) is an error, never a
crash (h5py 3.16 / HDF5 2.0 segfault when a write to disk fails, h5py issue #914)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

import score4
from score4.files import atomic_h5
from score4.source.vertex_file import read_vertex_file

from conftest import config_dict, tmpfs_mount_command

SRC = str(Path(score4.__file__).resolve().parents[1])  # this score4, also in subprocesses


def test_interrupted_writer_leaves_nothing_and_keeps_the_old_file(tmp_path):
    out = tmp_path / "r.h5"
    with atomic_h5(out) as f:
        f["x"] = np.arange(3)

    def interrupted_write():
        with atomic_h5(out) as f:
            f["x"] = np.arange(10)
            raise KeyboardInterrupt  # e.g. Ctrl-C half-way through writing

    with pytest.raises(KeyboardInterrupt):
        interrupted_write()
    with h5py.File(out, "r") as f:
        assert f["x"][()].tolist() == [0, 1, 2]
    assert [p.name for p in tmp_path.iterdir()] == ["r.h5"]


# A process limited to files of LIMIT bytes (RLIMIT_FSIZE; SIGXFSZ ignored, so a write past the
# limit fails with EFBIG as a write to a full disk fails with ENOSPC) writes a results chunk or
# a vertex file of ~1 MB over an existing file.
_WRITER = textwrap.dedent(
    """
    import resource, signal, sys
    import numpy as np
    from score4.errors import Score4Error
    from score4.runner.output import write_chunk
    from score4.source.primaries import Primaries
    from score4.source.vertex_file import write_vertex_file

    kind, out, limit = sys.argv[1], sys.argv[2], int(sys.argv[3])
    n, rng = 4000, np.random.default_rng(3)
    p = Primaries(
        event=np.arange(n), particle=np.array(["alpha"] * n), energy=np.full(n, 5.3),
        position=rng.random((n, 3)), direction=np.tile([0.0, 0.0, 1.0], (n, 1)),
        extra={"depth": rng.random(n)},
    )
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    try:
        if kind == "chunk":
            names = [f"v{k}" for k in range(20)]
            write_chunk(out, 0, names, {"edep": rng.random((n, 20))}, p)
        else:
            write_vertex_file(out, p, {"run": {"seed": 1}}, 1)
    except Score4Error as err:
        print(err)
        sys.exit(3)
    """
)


@pytest.mark.parametrize("kind", ["chunk", "vertices"])
def test_a_write_past_a_file_size_limit_is_an_error_and_keeps_the_old_file(tmp_path, kind):
    out = tmp_path / "x.h5"
    with atomic_h5(out) as f:
        f["old"] = np.arange(5)
    before = out.read_bytes()
    done = subprocess.run(
        [sys.executable, "-c", _WRITER, kind, str(out), str(200_000)],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": SRC},
        timeout=120,
    )
    assert done.returncode == 3, (done.returncode, done.stderr[-2000:])  # not -11 (SIGSEGV)
    assert done.stdout.startswith(f"cannot write {out}: ")
    assert "File too large" in done.stdout
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.h5"]  # no .partial left


def test_score4_vertices_on_a_full_disk_exits_with_an_error_and_keeps_the_old_file(tmp_path):
    # A real full disk: a 512 kB tmpfs in a private mount namespace. The old vertex file
    # (100 events) fits; the new one (20 000 events) does not.
    mnt = tmp_path / "small_disk"
    mnt.mkdir()
    unshare = tmpfs_mount_command(mnt)
    if unshare is None:
        pytest.skip("cannot mount a tmpfs in a private mount namespace here (unshare -m / -rm)")
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump(config_dict()))
    score4_vertices = f"{sys.executable} -m score4.cli.main vertices {config} --out {mnt}/v.h5"
    script = (
        f"mount -t tmpfs -o size=512k tmpfs {mnt} || exit 99; "
        f"{score4_vertices} --n 100 || exit 98; cp {mnt}/v.h5 {tmp_path}/before.h5; "
        f"{score4_vertices} --n 20000 --overwrite 2> {tmp_path}/err.txt; "
        f"echo $? > {tmp_path}/rc.txt; "
        f"cp {mnt}/v.h5 {tmp_path}/after.h5; ls -a {mnt} > {tmp_path}/ls.txt"
    )
    env = {**os.environ, "PYTHONPATH": SRC}
    subprocess.run([*unshare, "sh", "-c", script], check=True, timeout=300, env=env)
    err = (tmp_path / "err.txt").read_text()
    assert (tmp_path / "rc.txt").read_text().strip() == "2", err  # not 139 (SIGSEGV)
    assert err.startswith(f"score4: error: cannot write {mnt}/v.h5: "), err
    assert "the disk is full" in err
    assert "Traceback" not in err
    assert (tmp_path / "after.h5").read_bytes() == (tmp_path / "before.h5").read_bytes()
    assert read_vertex_file(tmp_path / "after.h5").n_events == 100
    assert (tmp_path / "ls.txt").read_text().split() == [".", "..", "v.h5"]


_FILL = textwrap.dedent(
    """
    import sys
    import numpy as np
    import score4.files as files
    from score4.errors import Score4Error

    files.check_free_space = lambda path, nbytes: None  # let the write itself meet the full disk
    try:
        with files.atomic_h5(sys.argv[1]) as f:
            f["x"] = np.random.default_rng(0).random(100_000)  # 800 kB
    except Score4Error as err:
        print(err)
        sys.exit(3)
    """
)


def test_a_write_that_meets_a_full_disk_is_an_error_and_keeps_the_old_file(tmp_path):
    # Past the free-space check (a race, a quota): the write fails on a real full disk, a 256 kB
    # tmpfs in a private mount namespace, with ENOSPC.
    mnt = tmp_path / "small_disk"
    mnt.mkdir()
    unshare = tmpfs_mount_command(mnt)
    if unshare is None:
        pytest.skip("cannot mount a tmpfs in a private mount namespace here (unshare -m / -rm)")
    script = (
        f"mount -t tmpfs -o size=256k tmpfs {mnt} || exit 99; echo old > {mnt}/x.h5; "
        f"{sys.executable} -c '{_FILL}' {mnt}/x.h5 > {tmp_path}/out.txt 2>&1; "
        f"echo $? > {tmp_path}/rc.txt; ls -a {mnt} > {tmp_path}/ls.txt; cp {mnt}/x.h5 {tmp_path}"
    )
    env = {**os.environ, "PYTHONPATH": SRC}
    subprocess.run([*unshare, "sh", "-c", script], check=True, timeout=120, env=env)
    said = (tmp_path / "out.txt").read_text()
    assert (tmp_path / "rc.txt").read_text().strip() == "3", said  # not 139 (SIGSEGV)
    assert said == f"cannot write {mnt}/x.h5: [Errno 28] No space left on device\n"
    assert (tmp_path / "x.h5").read_text() == "old\n"
    assert (tmp_path / "ls.txt").read_text().split() == [".", "..", "x.h5"]
