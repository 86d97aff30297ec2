"""How fast a huge run starts and stops: chunk planning, and Ctrl-C during the first chunk.

    .venv/bin/python benchmarks/bench_interrupt.py [--events 1e11] [--wait 8] [--repeat 3]

Prints the time to plan the chunks of ``--events`` events (lazy: no per-chunk objects), then
starts ``score4 run examples/flat_alpha.yaml --events N --jobs 2`` ``--repeat`` times, sends
SIGINT ``--wait`` seconds after the start and prints how long the run took to exit after it
(and its exit status, 130 expected). The machine is shared: the figures are noisy.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", default="1e11")
    parser.add_argument("--wait", type=float, default=8.0)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    from score4.runner.engine import plan_chunks

    n = int(float(args.events))
    t = time.perf_counter()
    plan = plan_chunks(n, 10_000, 2)
    last = plan[-1]
    print(
        f"plan of {n:.3g} events: {len(plan)} chunks of {plan.size} (last {last}) in "
        f"{(time.perf_counter() - t) * 1e3:.3f} ms"
    )
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "score4.cli.main",
                    "run",
                    str(ROOT / "examples" / "flat_alpha.yaml"),
                    "--events",
                    args.events,
                    "--jobs",
                    "2",
                    "--out",
                    f"{tmp}/x.h5",
                    "-q",
                ],
                stderr=subprocess.PIPE,
                text=True,
                start_new_session=True,
            )
            time.sleep(args.wait)
            t = time.monotonic()
            os.kill(proc.pid, signal.SIGINT)
            code = proc.wait(timeout=120)
            assert proc.stderr is not None
            said = proc.stderr.read().strip().splitlines()
            print(
                f"SIGINT after {args.wait:g} s: exit {code} after {time.monotonic() - t:.2f} s "
                f"({said[-1] if said else ''})"
            )


if __name__ == "__main__":
    main()
