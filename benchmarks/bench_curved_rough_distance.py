"""The cost of distances to the rough surface of a curved rough layer
(:class:`score4.world.rough_distance.CurvedRoughSurfaceDistance`) against the smooth face's.

    python benchmarks/bench_curved_rough_distance.py [--points 20000] [--rounds 3]

10 um pyramids (0.5 mm patches of 50 x 50) bent onto the side wall of a silicon tube of radius
5 mm and length 2 mm; points drawn uniformly over the wall from 30 um under it to 11 um over it
(under, in and over the pyramids, the region alpha steps fill). Per round, in this process: the
CPU time of the rough distance (first use excluded) and of the smooth face's, on the same
points. Medians over interleaved rounds, per point.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from stamp import stamp


def main() -> None:
    from bench_curved import write_cylinder  # this folder is on sys.path when run as a script

    from score4.inputs.config import parse_config
    from score4.world.face_distance import face_distance
    from score4.world.resolve import build_scene
    from score4.world.rough_distance import CurvedRoughSurfaceDistance
    from score4.world.scene import CurvedRoughLayer

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=20000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print(stamp())
    pyramids = {"kind": "spikes", "nx": 50, "ny": 50, "width": "10 um", "height": "10 um"}
    with tempfile.TemporaryDirectory() as tmp:
        gdml = Path(tmp) / "tube.gdml"
        write_cylinder(gdml, 5.0, 1.0)
        config = {
            "physics": "lite",
            "world": {"gdml": str(gdml)},
            "surfaces": {"p": pyramids},
            "targets": [{"volume": "cyl", "rough": [{"face": "outer", "surface": "p"}]}],
            "source": {
                "particle": "geantino",
                "energy": "1 MeV",
                "surface": {"volume": "cyl", "face": "outer"},
            },
            "run": {"events": 100, "seed": 3},
        }
        (layer,) = build_scene(parse_config(config)).layers
    assert isinstance(layer, CurvedRoughLayer)
    lay = layer.ring_layout
    rng = np.random.default_rng(2)
    n = args.points
    (u0, u1), (v0, v1) = lay.face.extent
    u, v, h = rng.uniform(u0, u1, n), rng.uniform(v0, v1, n), rng.uniform(-0.03, 0.011, n)
    world = layer.target.to_world(lay.face.point(u, v) + h[:, None] * lay.face.normal(u, v))
    rough = CurvedRoughSurfaceDistance(layer)
    rough(world[:10])  # the k-d trees built
    shape = layer.target.shape
    times: dict[str, list[float]] = {"rough": [], "smooth": []}
    for _ in range(args.rounds):
        t = time.process_time()
        rough(world)
        times["rough"].append(time.process_time() - t)
        t = time.process_time()
        face_distance(shape, ("outer",), layer.target.to_local(world))
        times["smooth"].append(time.process_time() - t)
    per = {k: statistics.median(x) / n * 1e6 for k, x in times.items()}
    print(f"rings {len(lay.v)}, cells {lay.n_cells}, window {rough.window} cells each way")
    print(f"rough (bent tops): {per['rough']:.2f} us per point")
    print(f"smooth face:       {per['smooth']:.3f} us per point")


if __name__ == "__main__":
    main()
