"""Cost of building HDF5 files in memory (files.atomic_h5) against HDF5 writing to disk itself.

    .venv/bin/python benchmarks/bench_h5_write.py [--events 2e6] [--chunks 20] [--repeat 3]

Writes ``--chunks`` chunk files of Po-210-like events (an alpha and a Pb-206 recoil per event,
edep and track length in 2 volumes, extras depth/facet/patch), then merges them into one
results file (score4.runner.output.merge_chunks) in a fresh process per merge, alternately:

``memory``  the library as it is: HDF5 builds the file in a BytesIO image, then plain I/O
            writes the image to the temporary file (``files.atomic_h5``);
``direct``  the former way: ``h5py.File(tmp, "w")`` on the temporary file (can segfault when
            the write fails, h5py issue #914).

Printed per merge: wall and CPU seconds, the peak RSS of the merging process above its RSS
before the merge, and the size of the merged file. The machine is shared: compare the two
columns within one invocation.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _chunk_primaries(n: int, rng):
    from score4.source.primaries import Primaries

    event = np.repeat(np.arange(n), 2)
    rows = 2 * n
    direction = rng.normal(size=(rows, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return Primaries(
        event=event,
        particle=np.tile(["alpha", "Pb206"], n),
        energy=np.tile([5.304, 0.103], n),
        position=rng.random((rows, 3)),
        direction=direction,
        extra={
            "depth": rng.random(rows) * 1e-4,
            "facet": rng.integers(0, 10_000, rows),
            "patch": rng.integers(0, 40_000, rows),
        },
    )


def write_chunks(folder: Path, events: int, chunks: int) -> list[Path]:
    from score4.runner.output import write_chunk

    rng = np.random.default_rng(1)
    size = events // chunks
    paths = []
    for i in range(chunks):
        first = i * size
        n = size if i < chunks - 1 else events - first
        scores = {"edep": rng.random((n, 2)), "track_length": rng.random((n, 2))}
        path = folder / f"chunk-{i:06d}.h5"
        write_chunk(path, first, ["crystal", "world"], scores, _chunk_primaries(n, rng))
        paths.append(path)
    return paths


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _rss_now_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 2**20


def merge_once(way: str, chunk_list: str, out: str) -> None:
    """In a fresh process: merge the chunks; print one JSON line of figures."""
    import h5py

    import score4.runner.output as output
    from score4.files import atomic_output

    if way == "direct":

        @contextlib.contextmanager
        def direct_h5(path):
            with atomic_output(path) as tmp, h5py.File(tmp, "w") as f:
                f.attrs["format"] = output.FORMAT
                f.attrs["format_version"] = output.FORMAT_VERSION
                yield f

        output.results_h5 = direct_h5
    paths = [Path(p) for p in json.loads(Path(chunk_list).read_text())]
    before = _rss_now_mb()
    wall, cpu = time.perf_counter(), time.process_time()
    output.merge_chunks(paths, Path(out), {"seed": 1})
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(
        json.dumps(
            {
                "way": way,
                "wall_s": wall,
                "cpu_s": cpu,
                "rss_before_MB": before,
                "peak_rss_MB": _rss_mb(),
                "file_MB": Path(out).stat().st_size / 2**20,
            }
        )
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", default="2e6")
    parser.add_argument("--chunks", type=int, default=20)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--merge-once", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.merge_once:
        merge_once(*args.merge_once)
        return
    events = int(float(args.events))
    with tempfile.TemporaryDirectory(dir=Path.cwd()) as tmp:
        folder = Path(tmp)
        t = time.perf_counter()
        paths = write_chunks(folder, events, args.chunks)
        size = sum(p.stat().st_size for p in paths) / 2**20
        print(
            f"{args.chunks} chunk files, {events:.3g} events, {size:.1f} MiB, "
            f"written in {time.perf_counter() - t:.1f} s"
        )
        listing = folder / "chunks.json"
        listing.write_text(json.dumps([str(p) for p in paths]))
        print("way       wall s   cpu s  RSS before MiB  peak-before MiB  file MiB")
        for _ in range(args.repeat):
            for way in ("memory", "direct"):
                out = folder / f"merged-{way}.h5"
                done = subprocess.run(
                    [sys.executable, __file__, "--merge-once", way, str(listing), str(out)],
                    check=True,
                    capture_output=True,
                    text=True,
                )
                r = json.loads(done.stdout.strip().splitlines()[-1])
                print(
                    f"{way:8} {r['wall_s']:7.2f} {r['cpu_s']:7.2f} {r['rss_before_MB']:15.0f} "
                    f"{r['peak_rss_MB'] - r['rss_before_MB']:16.0f} {r['file_MB']:9.1f}"
                )
                out.unlink()


if __name__ == "__main__":
    main()
