"""How far below the true distance the activeness distance to a rough face of a boolean lies
(:meth:`score4.world.boolean_distance.BooleanDistance.to_faces`: a rough face is measured by its
whole layer, the flat cells off the boolean's surface included, a lower bound).

    python benchmarks/bench_rough_face_bound.py [--points 4000]

A copper box (20 mm) less a cone (r 2 mm at its floor 5 mm below the top, widening to 3 mm),
``into: true`` on the floor (0.5 mm patches of 5 x 5 pyramids, 20 um): the floor's layer is a
square grid over the disk, its cells off the disk flat squares at the floor's level in the
copper. Points drawn in the copper within 1 mm of the floor's level and 1.5 mm of its rim; the
reference distance by brute force: the patch tops of the kept cells (every facet) and a grid of
spacing 2 um on the floor's disk outside the kept cells (2 um / sqrt 2 of the truth). Prints
the share of points where ``to_faces`` is more than 1 um and 2 um (the grid's error) below the
reference, the largest gap, and where it lies.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4000)
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from score4.inputs.config import parse_config
    from score4.shapes.mesh_shape import _tri_distance
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
        rng = np.random.default_rng(1)
        n = args.points
        rho = np.sqrt(rng.uniform(0.5**2, 3.5**2, 3 * n))
        phi = rng.uniform(0, 2 * np.pi, 3 * n)
        z = 5.0 - t - rng.uniform(0.0, 1.0, 3 * n)  # below the floor's (grown) level, box frame
        local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
        local = local[target.shape.signed_distance(local) < 0][:n]  # in the copper
        world = target.to_world(local)
        got = distance.to_faces(("second.-z",), world)
        # reference: every facet of the kept cells' patch tops, the disk's grid outside them
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
        ref = np.minimum(patch, cKDTree(flat).query(q)[0])
        gap = ref - got
        print(f"points {len(q)} in the copper up to 1 mm below the floor, rho 0.5 .. 3.5 mm")
        print(f"layer thickness {t * 1e3:.2f} um")
        for cut in (1e-3, 2e-3):
            share = 100 * (gap > cut).mean()
            print(f"to_faces below the reference by > {cut * 1e3:g} um: {share:.1f} %")
        k = int(np.argmax(gap))
        at = f"rho {np.hypot(*local[k, :2]):.3f} mm, {5.0 - local[k, 2]:.3f} mm below the floor"
        print(f"largest gap {gap[k]:.4f} mm at {at} ({ref[k]:.4f} against {got[k]:.4f})")
        off = np.hypot(local[:, 0], local[:, 1]) > r
        print(
            f"median gap beyond the grown floor's rim (rho > {r:.4f} mm): "
            f"{np.median(gap[off]):.4f} mm; within it: {np.median(gap[~off]):.4f} mm"
        )


if __name__ == "__main__":
    main()
