"""The cost of step distances in a boolean solid with a rough face
(:mod:`score4.world.boolean_distance`) against the rough surface's distance alone.

    python benchmarks/bench_boolean_distance.py [--points 20000] [--rounds 5]

A copper box (20 mm) less a tube (r 5 mm) along z, written by pyg4ometry in a temporary folder;
0.5 mm patches of 5 x 5 pyramids (20 um) on the box's +z face around the bore. Points drawn in
the copper and the patches within 20 um of that face. Per interleaved round, the CPU time of the
face's rough surface distance alone (:class:`score4.world.rough_distance.RoughSurfaceDistance`)
and of the whole distance the steps get (``TargetDistance.to_surface``: the rough box combined
with the tube, the box's other faces, the test of the patches); medians. Then activeness on the
rough face and the bore's wall (``to_faces``): the wall as it is on the boolean
(:class:`score4.world.kept_face_distance.KeptFaceDistance`: its nearest point's test, and the
rim where that point is cut away) against the wall whole (the lower bound used before), for the
same points and for points drawn in the whole copper; and the rim's one-off build.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from stamp import stamp


def write_world(path: Path) -> Path:
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 100, 100, 100, reg), "G4_Galactic", "W", reg)
    box = s.Box("cut_a", 20, 20, 20, reg)
    hole = s.Tubs("cut_b", 0, 5, 40, 0, 2 * np.pi, reg)
    cut = s.Subtraction("cutbox_s", box, hole, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "cutbox_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "cutbox", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def main() -> None:
    from score4.inputs.config import parse_config
    from score4.world.activeness import target_distances
    from score4.world.resolve import build_scene
    from score4.world.rough_distance import RoughSurfaceDistance

    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    print(stamp())
    with tempfile.TemporaryDirectory() as tmp:
        gdml = write_world(Path(tmp) / "cutbox.gdml")
        pyramids = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
        data = {
            "physics": "lite",
            "world": {"gdml": str(gdml)},
            "surfaces": {"p": pyramids},
            "targets": [{"volume": "cutbox", "rough": [{"face": "first.+z", "surface": "p"}]}],
            "source": {
                "particle": "alpha",
                "energy": "5.3 MeV",
                "surface": {"volume": "cutbox", "face": "first.+z"},
            },
            "output": {"steps": True},
        }
        scene = build_scene(parse_config(data))
    (distance,) = target_distances(scene)
    assert distance is not None
    layer = scene.layers[0]
    target = scene.target("cutbox")
    rng = np.random.default_rng(1)
    n = args.points
    local = np.column_stack([rng.uniform(-9.9, 9.9, (n, 2)), rng.uniform(9.98, 10.02, n)])
    p = target.to_world(local[np.hypot(local[:, 0], local[:, 1]) > 5.0])
    p = p[target.contains(p) | layer.contains(p)]
    rough = RoughSurfaceDistance(layer)
    rough(p[:10])  # the first use builds the k-d trees
    distance.to_surface(p[:10])
    alone, whole = [], []
    for _ in range(args.rounds):
        c0 = time.process_time()
        rough(p)
        alone.append(time.process_time() - c0)
        c0 = time.process_time()
        distance.to_surface(p)
        whole.append(time.process_time() - c0)
    a, w = statistics.median(alone), statistics.median(whole)
    print(f"{len(p)} points within 20 um of the rough face, {args.rounds} rounds (CPU medians)")
    print(f"rough surface alone: {a / len(p) * 1e6:.2f} us per point")
    print(f"boolean to_surface: {w / len(p) * 1e6:.2f} us per point, x{w / a:.2f}")
    faces_rows(distance, rough, target, p, rng, args.rounds)


def faces_rows(distance, rough, target, near, rng, rounds: int) -> None:
    """to_faces(first.+z rough, second.outer smooth): the wall kept against the wall whole."""
    from score4.world.boolean_distance import leaf_face_distance

    boolean = distance.boolean
    faces = ("first.+z", "second.outer")
    c0 = time.process_time()
    boolean.kept_faces(("second.outer",)).rim()
    print(f"rim of second.outer built once: {time.process_time() - c0:.3f} s CPU")

    def whole_faces(world: np.ndarray) -> np.ndarray:  # the lower bound before
        local = target.to_local(world)
        d = np.minimum(leaf_face_distance(boolean.shape, ("second.outer",), local), rough(world))
        s = boolean.to_surface(world)
        return np.where(s > 0, np.maximum(s, d), 0.0)

    local = rng.uniform(-10, 10, (len(near), 3))
    bulk = target.to_world(local[np.hypot(local[:, 0], local[:, 1]) > 5.0])
    for label, p in (("near the rough face", near), ("in the whole copper", bulk)):
        kept, old = [], []
        for _ in range(rounds):
            c0 = time.process_time()
            distance.to_faces(faces, p)
            kept.append(time.process_time() - c0)
            c0 = time.process_time()
            whole_faces(p)
            old.append(time.process_time() - c0)
        k, o = statistics.median(kept), statistics.median(old)
        print(
            f"to_faces {label}: wall kept {k / len(p) * 1e6:.2f} us per point, "
            f"wall whole {o / len(p) * 1e6:.2f} us, x{k / o:.2f}"
        )


if __name__ == "__main__":
    main()
