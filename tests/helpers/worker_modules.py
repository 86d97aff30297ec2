"""A local worker (``score4.sim.worker.worker_main``) run for one chunk in this process, then
the modules it imported (for tests/test_worker_start.py; run it in a spawned process).

The worker runs in the main thread, as in a process the engine starts; a second thread plays
the engine's side of the pipe: it waits for ``ready``, sends one chunk, then ``None``.
"""

from __future__ import annotations

import multiprocessing as mp
import sys
import threading


def run_worker(blob: bytes, n_events: int) -> tuple[list[str], list[tuple]]:
    """Run ``worker_main`` on the pickled spec ``blob`` for events 0 .. n_events - 1; return
    the names in ``sys.modules`` afterwards and the messages the worker sent."""
    from score4.sim.worker import Chunk, worker_main

    engine_end, worker_end = mp.Pipe()
    messages: list[tuple] = []

    def engine() -> None:
        while True:
            msg = engine_end.recv()
            messages.append(msg if msg[0] != "ready" else ("ready",))
            if msg[0] == "ready":
                engine_end.send(Chunk(0, 0, n_events))
            elif msg[0] in ("done", "error"):
                engine_end.send(None)
                return

    thread = threading.Thread(target=engine)
    thread.start()
    worker_main(blob, worker_end)
    thread.join(timeout=60)
    return sorted(sys.modules), messages
