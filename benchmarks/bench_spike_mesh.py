"""Time to build the exact top mesh and the closed body of pyramid grids (10^4 .. 10^6 spikes).

Run: ``.venv/bin/python benchmarks/bench_spike_mesh.py [--max-exponent 6]``. Prints one line per
size: spike count, faces of the closed body, seconds for the grid (heights), top mesh, closed
body, the watertight check and the exact mesh metrology, and the peak resident memory so far.
"""

from __future__ import annotations

import argparse
import functools
import resource
import time

from score4.surface.metrology import mesh_parameters
from score4.surface.spikes import SpikeGrid
from score4.surface.triangle_mesh import closed_body, is_watertight


def _timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--max-exponent", type=int, default=6, help="largest grid has 10^k spikes (default 6)"
    )
    args = parser.parse_args()
    print(
        f"{'spikes':>9} {'faces':>9} {'grid s':>7} {'top s':>7} {'body s':>7} {'check s':>8} "
        f"{'metro s':>8} {'peak RSS MB':>11}"
    )
    for k in range(4, args.max_exponent + 1):
        n = 10 ** (k // 2)
        kwargs = dict(
            nx=n,
            ny=10**k // n,
            width_x=0.005,
            width_y=0.005,
            mean_height=0.005,
            height_sigma=0.001,
            seed=1,
        )
        grid, t_grid = _timed(functools.partial(SpikeGrid, **kwargs))
        top, t_top = _timed(grid.top_mesh)
        body, t_body = _timed(closed_body, top, 0.1)
        ok, t_check = _timed(is_watertight, body)
        assert ok, "closed body is not watertight"
        _, t_metro = _timed(mesh_parameters, top)
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(
            f"{grid.n_spikes:>9} {body.n_faces:>9} {t_grid:7.3f} {t_top:7.3f} {t_body:7.3f} "
            f"{t_check:8.3f} {t_metro:8.3f} {rss:11.0f}"
        )


if __name__ == "__main__":
    main()
