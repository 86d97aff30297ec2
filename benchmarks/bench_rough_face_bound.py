"""How far below the true distance the activeness distance to a rough face of a boolean lies
(:meth:`score4.world.boolean_distance.BooleanDistance.to_faces`), before and after the exact
distance of :mod:`score4.world.rough_face_distance` (patch tops and the flat rest on the face).
Before: the face's whole layer (its flat cells off the boolean's surface included), raised
below the layer's level to the distance to the face at that level (``BooleanDistance._beside``,
still used for curved layers).

    python benchmarks/bench_rough_face_bound.py [--points 4000]

A copper box (20 mm) less a cone (r 2 mm at its floor 5 mm below the top, widening to 3 mm),
``into: true`` on the floor (0.5 mm patches of 5 x 5 pyramids, 20 um): the floor's layer is a
square grid over the disk, its cells off the disk flat squares at the floor's level in the
copper. Two sets of points in the volume (copper and patches), rho 0.5 .. 3.5 mm: up to 1 mm
below the floor's level, and near it (50 um below to the layer's top). The reference distance
by brute force: the patch tops of the kept cells (every facet) and a grid of spacing 2 um on
the floor's disk outside the kept cells (2 um / sqrt 2 of the truth). Prints, per set, the
share of points where the distance is more than 1 um and 2 um (the grid's error) below the
reference, the largest gap and where it lies, and the CPU time per point.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree
from stamp import stamp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4000)
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from score4.inputs.config import parse_config
    from score4.world.activeness import target_distances
    from score4.world.resolve import build_scene

    from helpers.boolean_worlds import write_box_holes

    with tempfile.TemporaryDirectory() as tmp:

        def holes(s, reg) -> dict:
            cone = s.Cons("cone_b", 0, 2, 0, 3, 10, 0, 2 * np.pi, reg)
            return {"cone": (cone, [0.0, 0.0, 10.0], 0.0)}

        gdml = write_box_holes(Path(tmp) / "cone.gdml", holes, 10.0)
        data = {
            "physics": "lite",
            "world": {"gdml": str(gdml)},
            "surfaces": {
                "p": {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
            },
            "targets": [
                {
                    "volume": "cone",
                    "rough": [{"face": "second.-z", "surface": "p", "into": True}],
                    "activeness": [{"fccd": "1 mm", "dlf": 0.5, "faces": ["second.-z"]}],
                }
            ],
            "source": {"particle": "geantino", "energy": "1 MeV", "volume": "cone"},
            "run": {"events": 1, "seed": 1},
        }
        scene = build_scene(parse_config(data))
        (distance,) = [d for d in target_distances(scene) if d is not None]
        layer = scene.layer("cone", "second.-z")
        target = scene.target("cone")
        assert layer is not None
        assert target.shape is not None
        t = layer.thickness
        boolean = distance.boolean
        assert boolean is not None
        rng = np.random.default_rng(1)
        n = args.points
        print(stamp())
        warm = target.to_world(np.array([[1.0, 0.0, 4.9], [2.5, 0.0, 4.9]]))
        distance.to_faces(("second.-z",), warm)  # the first use builds rims and k-d trees
        boolean._beside(
            "second.-z", warm, target.to_local(warm), distance.rough_distance("second.-z")(warm)
        )
        for label, lo, hi in (
            ("up to 1 mm below the floor's level", -1.0, 0.0),
            ("near the floor's level", -0.05, t),
        ):
            m = 4 * n
            rho = np.sqrt(rng.uniform(0.5**2, 3.5**2, m))
            phi = rng.uniform(0, 2 * np.pi, m)
            z = 5.0 - t + rng.uniform(lo, hi, m)  # about the floor's (grown) level, box frame
            local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
            world = target.to_world(local)
            keep = distance.to_surface(world) > 0  # in the volume: the copper and the patches
            local, world = local[keep][:n], world[keep][:n]
            c0 = time.process_time()
            got = distance.to_faces(("second.-z",), world)
            after = time.process_time() - c0
            c0 = time.process_time()
            whole = distance.to_surface(world)
            d = boolean._beside(
                "second.-z",
                world,
                target.to_local(world),
                distance.rough_distance("second.-z")(world),
            )
            old = np.where(whole > 0, np.maximum(whole, d), 0.0)
            before = time.process_time() - c0
            ref = reference(layer, target, world, t)
            print(f"{len(world)} points {label} (layer {t * 1e3:.2f} um)")
            over = np.hypot(local[:, 0], local[:, 1]) < 2.0 - 0.1 * t  # over the grown disk
            for name, value, cpu in (("before", old, before), ("after", got, after)):
                gap = ref - value
                print(
                    f"  {name}: largest gap over the disk {gap[over].max() * 1e3:.2f} um,"
                    f" beside it {gap[~over].max() * 1e3:.2f} um"
                )
                shares = ", ".join(
                    f"> {cut * 1e3:g} um {100 * (gap > cut).mean():.1f} %" for cut in (1e-3, 2e-3)
                )
                k = int(np.argmax(gap))
                at = f"rho {np.hypot(*local[k, :2]):.3f} mm, {5.0 - local[k, 2]:.3f} mm deep"
                print(
                    f"  {name}: below the reference by {shares}; largest gap {gap[k] * 1e3:.2f} um"
                    f" at {at}; above it by > 1e-9 mm: {100 * (gap < -1e-9).mean():.1f} %;"
                    f" {cpu / len(world) * 1e6:.1f} us CPU per point"
                )


def reference(layer, target, world: np.ndarray, t: float) -> np.ndarray:
    """Brute force: every facet of the kept cells' patch tops, a 2 um grid on the floor's disk
    outside the kept cells."""
    from score4.shapes.mesh_shape import _tri_distance

    q = layer.frame.to_local(world)
    cells = np.asarray(layer.cell_variants)
    centres = layer.cell_centres()
    px, py = layer.patch_size
    tops = []
    for j, i in zip(*np.nonzero(cells >= 0), strict=True):
        v = layer.variants[cells[j, i]]
        tri = np.asarray(v.top_mesh.vertices, float)[np.asarray(v.top_mesh.faces)]
        tops.append(tri + np.array([*centres[j, i], layer.base_thickness]))
    tri = np.concatenate(tops)
    patch = np.concatenate(
        [_tri_distance(q[k : k + 200], tri).min(axis=1) for k in range(0, len(q), 200)]
    )
    r = 2.0 - 0.1 * t  # the grown floor's radius
    h = 0.002
    g = np.arange(-r, r + h, h)
    x, y = np.meshgrid(g, g)
    x, y = x.ravel(), y.ravel()
    node = np.column_stack([x, y, np.zeros(len(x))])
    on_disk = np.hypot(*target.to_local(layer.frame.to_world(node))[:, :2].T) <= r
    nx, ny = cells.shape[1], cells.shape[0]
    ci = np.floor((x + nx * px / 2) / px).astype(int)
    cj = np.floor((y + ny * py / 2) / py).astype(int)
    inside = (ci >= 0) & (ci < nx) & (cj >= 0) & (cj < ny)
    under = np.zeros(len(x), dtype=bool)
    under[inside] = cells[cj[inside], ci[inside]] >= 0
    flat = node[on_disk & ~under]
    return np.minimum(patch, cKDTree(flat).query(q)[0])


if __name__ == "__main__":
    main()
