"""CPU of a Dask worker process from its first chunk task to the end of that chunk, and of the next.

    .venv/bin/python benchmarks/bench_dask_startup.py [--rounds 3] [--face-cm 1]
        [--baseline OLD/src]

Each round starts, per score4 version, a fresh Python process that plans
examples/paper_a_rough.yaml in lite physics (its rough face made ``--face-cm`` wide; 0: as the
example is), starts a local Dask cluster of one single-thread worker process and runs a chunk of
one event on it, then a second run of four one-event chunks (``DaskExecutor.execute``). From
the worker process's own CPU clock (``time.process_time`` through ``Client.run``), printed as
medians of ``--rounds`` interleaved rounds:

  first chunk   receiving the task, importing score4's worker modules, getting the plan
                (unpickled or rebuilt), building the Geant4 application, one event
  next chunks   the second run's CPU per chunk (the set-up kept; the run's plan sent again)

and whether the worker imported pydantic or score4.inputs.config. ``--baseline OLD/src`` runs
another score4 checkout (first on ``PYTHONPATH``) in the same rounds, for a before/after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MARK = "DASK-STARTUP "

_PROBE = """
import json, sys, tempfile, time
from pathlib import Path

import distributed
import yaml

from score4.inputs.config import parse_config
from score4.runner.dask_backend import DaskExecutor
from score4.runner.run_plan import plan_run
from score4.sim.runtime import resolve_physics
from score4.sim.worker import Chunk, WorkerSpec

face_cm = float(sys.argv[2])
data = yaml.safe_load(Path(sys.argv[1]).read_text())
data["physics"] = "lite"
if face_cm > 0:
    data["targets"][0]["size"] = [f"{face_cm} cm", f"{face_cm} cm", "1 mm"]


def cpu():
    return time.process_time()


def modules():
    return [m for m in ("pydantic", "score4.inputs.config") if m in sys.modules]


if __name__ == "__main__":
    config = parse_config(data, base_dir=Path(sys.argv[1]).parent)
    with (
        tempfile.TemporaryDirectory() as tmp,
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        spec = WorkerSpec(plan_run(config, physics=resolve_physics("lite")), Path(tmp))
        run = DaskExecutor(client, 1, echo=lambda m: None)
        (c0,) = client.run(cpu).values()
        events = list(run.execute(spec, [Chunk(0, 0, 1)]))
        assert ("done", 0) in events, events
        (c1,) = client.run(cpu).values()
        events = list(run.execute(spec, [Chunk(k, k, 1) for k in range(1, 5)]))
        assert ("done", 4) in events, events
        (c2,) = client.run(cpu).values()
        (imported,) = client.run(modules).values()
    print("DASK-STARTUP " + json.dumps([c1 - c0, (c2 - c1) / 4, imported]))
"""


def one_round(src: str | None, face_cm: float) -> list:
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    config = ROOT / "examples" / "paper_a_rough.yaml"
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, str(config), str(face_cm)],
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    lines = [line for line in done.stdout.splitlines() if line.startswith(MARK)]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"probe failed ({done.returncode}): {done.stderr[-2000:]}")
    result: list = json.loads(lines[-1][len(MARK) :])
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--face-cm", type=float, default=1.0)
    parser.add_argument("--baseline", help="the src folder of another score4 checkout")
    args = parser.parse_args()
    versions = (
        {"this": None} if args.baseline is None else {"this": None, "baseline": args.baseline}
    )
    rows: dict[str, list[list]] = {name: [] for name in versions}
    load0 = os.getloadavg()[0]
    for _ in range(args.rounds):
        for name, src in versions.items():
            rows[name].append(one_round(src, args.face_cm))
    face = f"{args.face_cm:g} cm face" if args.face_cm > 0 else "the example's face"
    print(
        f"Dask worker CPU, examples/paper_a_rough.yaml with {face}, lite physics, one worker "
        f"(median of {args.rounds} interleaved rounds; load {load0:.1f} -> "
        f"{os.getloadavg()[0]:.1f})"
    )
    for name, src in versions.items():
        first = statistics.median(r[0] for r in rows[name])
        later = statistics.median(r[1] for r in rows[name])
        label = f"{name}{f' ({src})' if src else ''}"
        print(
            f"  {label}: first chunk {first:.2f} s, next chunks {later:.3f} s CPU each; "
            f"first chunks {', '.join(f'{r[0]:.2f}' for r in rows[name])} s; "
            f"worker imported: {', '.join(rows[name][0][2]) or 'neither pydantic nor the config'}"
        )


if __name__ == "__main__":
    main()
