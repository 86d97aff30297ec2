"""How fast a cancelled Dask chunk stops on its worker, and what the stop check costs per event.

    .venv/bin/python benchmarks/bench_dask_cancel.py [--repeat 3]

On a local Dask cluster of one worker process: runs a 100-event chunk, then starts a chunk of
10⁶ events (flat_alpha-like: 5.3 MeV alphas on a silicon face, lite physics), cancels it
(``DaskExecutor.execute(...).close()``, what Ctrl-C or a failure does) ``--wait`` seconds after
it started, and prints the seconds until the worker executes no task (polled every 0.02 s),
and whether the worker process is the same one afterwards. Then the CPU time of the per-event
stop check (``Simulation._check_stop`` with an unset event), without Geant4. The machine is
shared: the figures are noisy.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import threading
import time
import timeit
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def _executing(client) -> int:
    return sum(client.run(lambda dask_worker: dask_worker.state.executing_count).values())


def _wait_for(condition, timeout: float) -> float | None:
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        if condition():
            return time.monotonic() - start
        time.sleep(0.02)
    return None


def cancel_latency(repeat: int, wait: float) -> None:
    import distributed

    from score4.inputs.config import parse_config
    from score4.runner.dask_backend import DaskExecutor
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import resolve_physics
    from score4.sim.worker import Chunk, WorkerSpec

    # the built-in example, small and in lite physics (no data sets needed)
    data = yaml.safe_load((ROOT / "examples" / "flat_alpha.yaml").read_text())
    data.update(physics="lite", run={"events": 100, "seed": 3})
    config = parse_config(data)
    with (
        tempfile.TemporaryDirectory() as tmp,
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        spec = WorkerSpec(plan_run(config, physics=resolve_physics("lite")), Path(tmp))
        pid = client.run(os.getpid)
        for k in range(repeat):
            todo = [Chunk(2 * k, 0, 100), Chunk(2 * k + 1, 100, 1_000_000)]
            events = DaskExecutor(client, 1, echo=lambda m: None).execute(spec, todo)
            for event in events:
                if event == ("done", 2 * k):
                    break
            _wait_for(lambda: _executing(client) == 1, 60)
            time.sleep(wait)
            t = time.monotonic()
            events.close()
            closed = time.monotonic() - t
            idle = _wait_for(lambda: _executing(client) == 0, 120)
            idle_text = "not within 120 s" if idle is None else f"{closed + idle:.2f} s"
            print(
                f"cancel {k + 1}: executor closed in {closed:.2f} s; worker idle after "
                f"{idle_text}; same worker process: {client.run(os.getpid) == pid}"
            )


def check_cost() -> None:
    from score4.sim.simulation import Simulation

    sim = Simulation.__new__(Simulation)  # no Geant4: only the check itself
    sim._stop, sim._stopped = threading.Event(), False
    n = 1_000_000
    per = min(timeit.repeat(sim._check_stop, number=n, repeat=5)) / n
    print(f"stop check per event: {per * 1e9:.0f} ns (best of 5 x {n})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--wait", type=float, default=1.0)
    args = parser.parse_args()
    cancel_latency(args.repeat, args.wait)
    check_cost()


if __name__ == "__main__":
    main()
