"""How far the activeness distance to a CURVED rough face of a boolean lies from the true one
(:meth:`score4.world.boolean_distance.BooleanDistance.to_faces`), before and after the exact
distance of :mod:`score4.world.rough_face_distance` for curved layers (the bent patch tops and
the face at the layer's level as the boolean keeps it, less the patch footprints). Before:
the face's whole layer's rough surface (every cell of its ring layout without a patch counted
as the smooth face there, those off the boolean's surface included; not raised below the
level: ``BooleanDistance._beside`` keeps a curved layer's distance).

    python benchmarks/bench_curved_face_bound.py [--points 600]

Two booleans of tests/helpers/boolean_worlds.py (``write_more_world``), 0.4 mm patches of 5 x 5
pyramids (20 um) on the curved face, activeness listing that face alone:

* ``cross``, a copper box (20 mm) with a rod (r 5 mm, 40 mm) through it (a union), rough on
  the rod's wall: the rings inside the box hold no patch; their flat cells lie in the copper.
* ``conebore``, a copper box less a cone (r 4 to 8 mm over 40 mm) through it, rough on the
  cone's wall: the rings beyond the box hold no patch; their flat cells lie in the air.

Points in the volume (copper and patches) within 0.1 rad of azimuth 0 (where each ring's
azimuth gap without cells lies: the bare face there is part of the surface): near the face
where it leaves the box (z 9 .. 11.5 mm, 1 mm either side of the face) and below the face
within the box's faces (z 1 .. 9 mm, 0 .. 1 mm below it). The reference by brute force: every
facet of the patch tops of the patch cells within 0.3 rad, and a grid of 2 um on the face
(within 0.3 rad and 2.5 mm of the points' z) where the boolean keeps it (its inside test: on
the surface) and no patch stands (outside the patch footprints). Prints per set, before and
after, for the face's own distance (``BooleanDistance.rough_face``) and for the whole
surface's (``to_surface``; activeness takes the larger of it and the face's), the share of
points more than 2 um (the grid's error) below and above the reference and the largest gap
each way and where it lies, and the CPU time per point of the face's distance before and
after (built once first: its CPU time is printed).
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

HALF = 10.0  # the box's half width, mm
WINDOW = 0.3  # azimuth window of the reference's facets and grid, rad
SPREAD = 0.1  # azimuth spread of the points, rad
GRID = 0.002  # the flat rest's grid, mm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=600)
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from score4.inputs.config import parse_config
    from score4.world.activeness import target_distances
    from score4.world.resolve import build_scene
    from score4.world.scene import CurvedRoughLayer

    from helpers.boolean_worlds import write_more_world

    print(stamp())
    with tempfile.TemporaryDirectory() as tmp:
        gdml = write_more_world(Path(tmp) / "more.gdml")
        for volume, radius in (
            ("cross", lambda z: 5.0 + 0 * z),
            ("conebore", lambda z: 6 + z / 10),
        ):
            pyramids = {"kind": "spikes", "nx": 5, "ny": 5, "width": "80 um", "height": "20 um"}
            data = {
                "physics": "lite",
                "world": {"gdml": str(gdml)},
                "surfaces": {"p": pyramids},
                "targets": [
                    {
                        "volume": volume,
                        "rough": [{"face": "second.outer", "surface": "p"}],
                        "activeness": [{"fccd": "1 mm", "dlf": 0.5, "faces": ["second.outer"]}],
                    }
                ],
                "source": {"particle": "geantino", "energy": "1 MeV", "volume": volume},
                "run": {"events": 1, "seed": 1},
            }
            scene = build_scene(parse_config(data))
            (distance,) = [d for d in target_distances(scene) if d is not None]
            layer = scene.layer(volume, "second.outer")
            target = scene.target(volume)
            assert isinstance(layer, CurvedRoughLayer)
            c0 = time.process_time()
            warm = target.to_world(np.array([[5.0, 0.0, 10.0]]))
            assert distance.boolean is not None
            distance.boolean.rough_face("second.outer", warm)  # builds the rest's sides, rims
            distance.rough_distance("second.outer")(warm)
            print(f"{volume}: the face's distance built in {time.process_time() - c0:.2f} s CPU")
            rng = np.random.default_rng(1)
            for label, zlo, zhi, below in (
                ("where the face leaves the box", HALF - 1.0, HALF + 1.5, (-1.0, 1.0)),
                ("below the face within the box", 1.0, HALF - 1.0, (0.0, 1.0)),
            ):
                m = 8 * args.points
                z = rng.uniform(zlo, zhi, m)  # +z only: the booleans are symmetric in z
                # the face's normal points out of the rod (cross), into the copper (conebore)
                sign = 1.0 if volume == "cross" else -1.0
                rho = radius(z) - sign * rng.uniform(*below, m)
                phi = rng.uniform(-SPREAD, SPREAD, m)
                local = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
                world = target.to_world(local)
                keep = distance.to_surface(world) > 0  # in the volume
                local, world = local[keep][: args.points], world[keep][: args.points]
                face = ("second.outer",)
                whole = distance.to_surface(world)
                boolean = distance.boolean
                assert boolean is not None
                c0 = time.process_time()
                layer_d = distance.rough_distance(face[0])(world)
                c1 = time.process_time()
                own = boolean.rough_face(face[0], world)
                c2 = time.process_time()
                old = np.maximum(whole, layer_d)
                ref = reference(layer, target, local)
                lay = layer.ring_layout
                j, _, xy = lay.locate(local)
                slot = (j < 0) | (np.abs(xy[:, 0]) > layer.patch_size[0] / 2)
                ends = 2 * np.pi * lay.radius - lay.count * lay.step * lay.radius
                print(
                    f"{volume}, {len(world)} points {label} (each ring's azimuth gap without"
                    f" cells up to {ends.max():.3f} mm wide, at azimuth"
                    f" {lay.phi_mid + np.pi:.2f} rad; {100 * slot.mean():.0f} % of the points"
                    " under it):"
                )
                for name, value in (
                    ("before", old),
                    ("after", distance.to_faces(face, world)),
                    ("the face's own (after)", own),
                    ("the whole surface's", whole),
                ):
                    gap = ref - value
                    out = []
                    for way, g in (("below", gap), ("above", -gap)):
                        k = int(np.argmax(g))
                        at = f"z {local[k, 2]:.2f}, rho {np.hypot(*local[k, :2]):.3f} mm"
                        out.append(
                            f"{way} by > 2 um {100 * (g > GRID).mean():.1f} %"
                            f" (largest {max(g[k], 0.0) * 1e3:.1f} um at {at})"
                        )
                    print(f"  {name}: {'; '.join(out)}")
                n = len(world)
                print(
                    f"  CPU per point, the face's distance: before {(c1 - c0) / n * 1e6:.0f} us,"
                    f" after {(c2 - c1) / n * 1e6:.0f} us"
                )


def reference(layer, target, local: np.ndarray) -> np.ndarray:
    """Brute force (``local``: the target's frame): every facet of the patch tops within
    :data:`WINDOW`, a :data:`GRID` grid on the kept face outside the patch footprints."""
    from score4.shapes.base import SURFACE
    from score4.shapes.mesh_shape import _tri_distance

    lay = layer.ring_layout
    face = lay.face
    cells = np.asarray(layer.cell_variants)
    px = layer.patch_size[0]
    zmin, zmax = local[:, 2].min() - 2.5, local[:, 2].max() + 2.5
    tops = []
    for j, _, k, phi in layer.cells():
        if (
            not zmin <= lay.ring_z(j) <= zmax
            or abs(np.mod(phi + np.pi, 2 * np.pi) - np.pi) > WINDOW
        ):
            continue
        tri = layer.bent(k, j).top_triangles.reshape(-1, 3)
        c, s = np.cos(phi), np.sin(phi)
        tri = np.column_stack(
            [
                c * tri[:, 0] - s * tri[:, 1],
                s * tri[:, 0] + c * tri[:, 1],
                tri[:, 2] + lay.ring_z(j),
            ]
        )
        tops.append(tri.reshape(-1, 3, 3))
    best = np.full(len(local), np.inf)
    if tops:
        tri = np.concatenate(tops)
        best = np.concatenate(
            [_tri_distance(local[k : k + 50], tri).min(axis=1) for k in range(0, len(local), 50)]
        )
    # the flat rest: the face where the boolean keeps it, outside the patch footprints
    on = layer.on_boolean
    vs = np.sort(face.locate(np.array([[5.0, 0.0, zmin], [5.0, 0.0, zmax]]))[1])
    rest = []
    for v in np.arange(vs[0], vs[1] + GRID, GRID):
        r = float(face.radius(v))
        u = np.arange(-WINDOW, WINDOW, GRID / r)
        p = face.point(u, np.full(len(u), v))
        codes = on.shape.inside(on.transform.inverse_apply(target.to_world(p)))
        j, i, xy = lay.locate(p)
        patch = j >= 0
        patch[patch] = cells[j[patch], i[patch]] >= 0
        patch &= np.abs(xy[:, 0]) <= px / 2
        rest.append(p[(codes == SURFACE) & ~patch])
    flat = np.concatenate(rest)
    if len(flat):
        best = np.minimum(best, cKDTree(flat).query(local)[0])
    return best


if __name__ == "__main__":
    main()
