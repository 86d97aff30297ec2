"""The Dask backend (score4 run --cluster): same chunks and seeds as local processes, so identical
results; resume across backends; existing schedulers and clients; faults; missing package.

Real (small) Geant4 runs on local Dask clusters of 2 worker processes.
"""

from __future__ import annotations

import os
import sys
import time

import h5py
import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError, Score4Error
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.runner.run_plan import plan_run
from score4.sim.runtime import resolve_physics
from score4.sim.worker import CRASH_HOOK, Chunk, WorkerSpec, chunk_path

from conftest import config_dict

# Each test starts several worker processes: under `make test` (pytest-xdist, -n 2) these run one
# after another on one xdist worker, not side by side with each other (Makefile: test).
pytestmark = pytest.mark.xdist_group("worker-processes")

distributed = pytest.importorskip("distributed")

RUN = {"events": 600, "seed": 13, "chunk_events": 100}


def quiet(msg: str) -> None:
    pass


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The configuration and its result with local worker processes."""
    config = parse_config(config_dict(run=RUN))
    out = tmp_path_factory.mktemp("ref") / "local.h5"
    return config, read_results(run(config, out, jobs=2, progress=False, echo=quiet))


@pytest.fixture(scope="module")
def cluster():
    """A running local Dask cluster of 2 single-thread worker processes (with nannies)."""
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as c:
        yield c


def assert_same_events(a, b) -> None:
    assert np.array_equal(a.event_id, b.event_id)
    assert np.array_equal(a.primary_energy, b.primary_energy)
    for name in a.edep:
        assert np.array_equal(a.edep[name], b.edep[name])
    for field in ("event", "particle", "energy", "position", "direction"):
        assert np.array_equal(getattr(a.primaries, field), getattr(b.primaries, field))


def test_cli_cluster_dask_gives_the_local_result(tmp_path, reference, capsys):
    _, local = reference
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(config_dict(run=RUN)))
    out = tmp_path / "dask.h5"
    assert (
        main(
            [
                "run",
                str(config_file),
                "--out",
                str(out),
                "--cluster",
                "dask",
                "--jobs",
                "2",
                "--quiet",
            ]
        )
        == 0
    )
    result = read_results(out)
    assert_same_events(result, local)
    assert result.run["backend"] == "dask local cluster (2 workers)"
    assert result.run["geant4_version"].startswith("11.")
    assert not (tmp_path / "dask.h5.parts").exists()
    # Geant4's output came back from the Dask workers, one log per worker process
    log = (tmp_path / "dask.geant4.log").read_text()
    assert "===== geant4-dask-" in log
    assert "Geant4 version" in log


def test_steps_and_activeness_on_dask_are_the_local_ones(tmp_path):
    """output.steps and targets[].activeness on a local Dask cluster: the same /stp tables
    (every column, every row, in the same order) and active energies as with local processes."""
    targets = [{**config_dict()["targets"][0], "activeness": [{"fccd": "5 um", "dlf": 0.5}]}]
    data = config_dict(
        targets=targets, run={"events": 120, "seed": 13, "chunk_events": 40}, output={"steps": True}
    )
    config = parse_config(data)
    local = run(config, tmp_path / "local.h5", jobs=1, progress=False, echo=quiet)
    dask = run(config, tmp_path / "dask.h5", cluster="dask", jobs=2, progress=False, echo=quiet)
    a, b = read_results(local), read_results(dask)
    assert b.run["backend"] == "dask local cluster (2 workers)"
    assert_same_events(a, b)
    np.testing.assert_array_equal(
        a.scores["active_edep"]["crystal"], b.scores["active_edep"]["crystal"]
    )
    assert (a.scores["active_edep"]["crystal"] < a.edep["crystal"]).any()
    with h5py.File(local, "r") as f, h5py.File(dask, "r") as g:
        columns = list(f["stp/crystal"])
        assert columns == list(g["stp/crystal"])
        assert len(f["stp/crystal/evtid"]) > 10 * 120
        for c in columns:
            np.testing.assert_array_equal(f["stp/crystal"][c][()], g["stp/crystal"][c][()])
        hit = np.flatnonzero(b.edep["crystal"] > 0)  # events numbered through the chunks
        assert np.array_equal(np.unique(g["stp/crystal/evtid"][()]), hit)


@pytest.mark.deep  # two more clusters; the CLI test above covers --cluster dask in make test
def test_existing_scheduler_address_and_client(tmp_path, reference, cluster):
    config, local = reference
    said = []
    result = read_results(
        run(
            config,
            tmp_path / "a.h5",
            cluster=cluster.scheduler_address,
            progress=False,
            echo=said.append,
        )
    )
    assert_same_events(result, local)
    assert result.run["backend"] == f"dask {cluster.scheduler_address}"
    # The workers now hold this configuration's Geant4 set-up. Another configuration on the same
    # workers, through a Client: they are restarted first (one Geant4 set-up per process).
    other = parse_config(config_dict(run={**RUN, "events": 300}, source={"energy": "4 MeV"}))
    with distributed.Client(cluster) as client:
        said.clear()
        result = read_results(
            run(other, tmp_path / "b.h5", cluster=client, progress=False, echo=said.append)
        )
        assert client.status == "running"  # a client given by the caller stays open
    assert any(
        "restarting 2 Dask worker(s) that hold another run's Geant4 set-up" in m for m in said
    )
    expected = read_results(run(other, tmp_path / "c.h5", jobs=2, progress=False, echo=quiet))
    assert_same_events(result, expected)
    assert result.primary_energy.max() == pytest.approx(4.0)


def test_resume_on_dask_of_a_run_started_locally(tmp_path, reference, monkeypatch):
    config, local = reference
    out = tmp_path / "r.h5"
    monkeypatch.setenv(CRASH_HOOK, "3")
    with pytest.raises(Score4Error, match=r"chunk 3 failed .* 5 of 6 chunks are finished"):
        run(config, out, jobs=2, progress=False, echo=quiet)
    monkeypatch.delenv(CRASH_HOOK)
    said = []
    result = read_results(
        run(config, out, jobs=2, resume=True, cluster="dask", progress=False, echo=said.append)
    )
    assert "resume: 5 of 6 chunks already finished" in said[0]
    assert_same_events(result, local)
    assert "notice: --jobs 2 but only 1 chunk(s) to run" in said[1]


def test_a_dying_dask_worker_fails_its_chunk(tmp_path, monkeypatch):
    import dask

    config = parse_config(config_dict(run={"events": 300, "seed": 2, "chunk_events": 100}))
    monkeypatch.setenv(CRASH_HOOK, "1")  # inherited by the local cluster's worker processes
    no_retry = dask.config.set(
        {"distributed.scheduler.allowed-failures": 0}
    )  # no retry on another worker
    with no_retry, pytest.raises(Score4Error) as info:
        run(config, tmp_path / "x.h5", jobs=2, cluster="dask", progress=False, echo=quiet)
    text = str(info.value)
    assert text.startswith(
        "run: chunk 1 failed (WorkerDied: the Dask worker processes that ran it died"
    )
    assert "2 of 3 chunks are finished and kept in" in text
    assert "--resume" in text
    assert sorted(p.name for p in (tmp_path / "x.h5.parts").glob("chunk-*.h5")) == [
        "chunk-000000.h5",
        "chunk-000002.h5",
    ]


#: Seconds after which a cancelled chunk that still runs counts as not stopped (a safety bound,
#: far above the stop time on a loaded machine, far below the chunk's own run time).
STOP_BOUND_S = 120.0


def _executing(client) -> int:
    """Tasks the workers are executing now (a cancelled task runs on until its function returns)."""
    counts = client.run(lambda dask_worker: dask_worker.state.executing_count)
    return sum(counts.values())


def _tracking(client, n_events: int) -> bool:
    """True once the worker's Geant4 run of ``n_events`` events has tracked one of them."""

    def probe() -> bool:
        from score4.runner import dask_backend

        sim = dask_backend._held.get("sim")  # the worker's Simulation (private: a test probe)
        primaries = getattr(sim, "_primaries", None)
        return primaries is not None and primaries.n_events == n_events and sim._next_event > 0

    return all(client.run(probe).values())


def _wait_for(condition, timeout: float) -> float | None:
    """Seconds until ``condition()`` held (polled every 0.05 s), or None after ``timeout``."""
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        if condition():
            return time.monotonic() - start
        time.sleep(0.05)
    return None


def test_a_cancelled_chunk_stops_on_its_worker_and_the_worker_runs_on(tmp_path):
    """Dask does not interrupt a running task: the chunk task must stop its Geant4 run itself."""
    from score4.runner.dask_backend import DaskExecutor

    config = parse_config(config_dict(run={"events": 100, "seed": 3}))
    spec = WorkerSpec(plan_run(config, physics=resolve_physics("lite")), tmp_path)
    # chunk 1 would run for minutes (~1 ms per event); one worker runs chunk 0 first
    todo = [Chunk(0, 0, 100), Chunk(1, 100, 1_000_000)]
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        pid = client.run(os.getpid)
        events = DaskExecutor(client, 1, echo=quiet).execute(spec, todo)
        for event in events:  # up to the end of chunk 0
            assert event[0] != "failed", event
            if event == ("done", 0):
                break
        assert _wait_for(lambda: _executing(client) == 1, STOP_BOUND_S) is not None  # chunk 1 runs
        # cancel once Geant4 tracks chunk 1's events (an event, not a time: sampling its
        # million vertices takes ~1 s idle and longer under load)
        assert _wait_for(lambda: _tracking(client, 1_000_000), STOP_BOUND_S) is not None
        events.close()  # what Ctrl-C or a failure does: the executor cancels the rest
        # Wait for the event (the worker executes nothing), not for a time: it takes ~0.1 s idle
        # and seconds under load (bench_dask_cancel.py); the bound only ends a broken stop,
        # where chunk 1 would run its million events (~20 min) to the end.
        stopped_after = _wait_for(lambda: _executing(client) == 0, STOP_BOUND_S)
        assert stopped_after is not None, "the cancelled chunk still runs on its worker"
        assert client.run(os.getpid) == pid  # stopped, not killed: the same worker process
        # the worker's Geant4 application gives the same events as before the cancelled run
        again = list(DaskExecutor(client, 1, echo=quiet).execute(spec, [Chunk(2, 0, 100)]))
        assert ("done", 2) in again

        # the worker got the plan resolved (run_plan.worker_pickle), as a local worker does: it
        # rebuilt no scene and imported no configuration models (a nested function: Dask sends
        # it by value, so the worker does not import this test module to run it)
        def parent_side_modules() -> list[str]:
            names = ("pydantic", "score4.inputs.config", "score4.world.resolve")
            return [m for m in names if m in sys.modules]

        assert list(client.run(parent_side_modules).values()) == [[]]
    written = sorted(p.name for p in tmp_path.glob("chunk-*"))
    assert written == ["chunk-000000.h5", "chunk-000002.h5"]  # nothing of chunk 1, no .partial
    with h5py.File(chunk_path(tmp_path, 0), "r") as a, h5py.File(chunk_path(tmp_path, 2)) as b:
        assert np.array_equal(a["events/edep/crystal"][()], b["events/edep/crystal"][()])
        assert np.count_nonzero(a["events/edep/crystal"][()]) > 0


def test_bad_input_found_on_a_dask_worker_is_a_config_error(tmp_path):
    config = parse_config(config_dict(run={"events": 100, "seed": 2}, source={"particle": "alpah"}))
    with pytest.raises(ConfigError, match=r"source\.particle: unknown name 'alpah'"):
        run(config, tmp_path / "p.h5", cluster="dask", progress=False, echo=quiet)
    assert list(tmp_path.iterdir()) == []


def test_bad_cluster_values(tmp_path, make_config):
    with pytest.raises(
        ConfigError,
        match=r"--cluster: 'localhost' is neither 'dask' .* nor a Dask scheduler address",
    ):
        run(make_config(), tmp_path / "x.h5", cluster="localhost", progress=False, echo=quiet)
    import dask

    short = dask.config.set({"distributed.comm.timeouts.connect": "2s"})
    with (
        short,
        pytest.raises(
            Score4Error,
            match=r"--cluster: cannot connect to the Dask scheduler at tcp://127.0.0.1:9",
        ),
    ):
        run(
            make_config(),
            tmp_path / "x.h5",
            cluster="tcp://127.0.0.1:9",
            progress=False,
            echo=quiet,
        )
    assert list(tmp_path.iterdir()) == []


def test_without_distributed_the_error_says_what_to_install(
    tmp_path, make_config, monkeypatch, capsys
):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(
        Score4Error, match=r"needs the 'distributed' package.*pip install 'score4\[cluster\]'"
    ):
        run(make_config(), tmp_path / "x.h5", cluster="dask", progress=False, echo=quiet)
    config_file = tmp_path / "c.yaml"
    config_file.write_text(yaml.safe_dump(config_dict()))
    assert (
        main(["run", str(config_file), "--out", str(tmp_path / "x.h5"), "--cluster", "dask"]) == 2
    )
    assert "score4[cluster]" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.yaml"]
