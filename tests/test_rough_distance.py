"""Distances to a rough surface (score4.world.rough_distance) against an independent brute force
over every facet of the layer, and against analytic cases: a point inside a pyramid, a flat
"rough" surface, points deep under the face."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.surface.triangle_mesh import TriangleMesh
from score4.world.activeness import face_distance, target_distances
from score4.world.rough_distance import RoughSurfaceDistance, point_triangle_distance
from score4.world.scene import FaceFrame, build_scene


def _brute_triangle(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(n, m) distances of points to triangles by the closest-point regions, written apart from
    the library: the foot of the perpendicular by a barycentric solve (Cramer's rule) if it falls
    inside, else the nearest of the three edges."""
    a, e0, e1 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    g00, g01, g11 = (e0 * e0).sum(1), (e0 * e1).sum(1), (e1 * e1).sum(1)
    det = g00 * g11 - g01 * g01
    out = np.empty((len(p), len(tri)))
    for n, x in enumerate(p):
        w = x - a
        r0, r1 = (w * e0).sum(1), (w * e1).sum(1)
        s, t = (g11 * r0 - g01 * r1) / det, (g00 * r1 - g01 * r0) / det
        inside = (s >= 0) & (t >= 0) & (s + t <= 1)
        foot = a + s[:, None] * e0 + t[:, None] * e1
        best = np.where(inside, np.linalg.norm(x - foot, axis=1), np.inf)
        for u, v in ((tri[:, 0], tri[:, 1]), (tri[:, 1], tri[:, 2]), (tri[:, 2], tri[:, 0])):
            d = v - u
            k = np.clip(((x - u) * d).sum(1) / (d * d).sum(1), 0, 1)
            best = np.minimum(best, np.linalg.norm(x - (u + k[:, None] * d), axis=1))
        out[n] = best
    return out


def _all_facets(rd: RoughSurfaceDistance) -> np.ndarray:
    """Every top facet of the layer in the layer's frame (cells without patch: two flat
    triangles at z = 0)."""
    out = []
    for j in range(rd.ny):
        for i in range(rd.nx):
            k = rd.cells[j, i]
            shift = np.array([rd.cx[i], rd.cy[j], 0.0])
            if k >= 0:
                out.append(rd.variants[k].tri + shift)
            else:
                hx, hy = rd.px / 2, rd.py / 2
                c = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]]) + shift
                out.append(np.stack([c[[0, 1, 2]], c[[0, 2, 3]]]))
    return np.concatenate(out)


def _scene(surface: dict, size=("0.3 mm", "0.2 mm", "2 mm"), base: str = "1 um", **target):
    data = {
        "surfaces": {"s": surface},
        "targets": [
            {
                "name": "c",
                "material": "G4_Ge",
                "size": list(size),
                "position": ["0 mm", "0 mm", "-1 mm"],
                "rough": [{"face": "+z", "surface": "s", "base_thickness": base}],
                **target,
            }
        ],
        "source": {
            "particle": "alpha",
            "energy": "5 MeV",
            "surface": {"volume": "c", "face": "+z"},
        },
        "run": {"events": 10},
    }
    return build_scene(parse_config(data))


PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "10 um", "height": "10 um"}
RANDOM = {
    "kind": "random",
    "nx": 32,
    "ny": 32,
    "pitch": "1.5625 um",
    "sq": "2 um",
    "corr_length": "8 um",
    "seed": 3,
}


def _points(rng, n: int, half: tuple[float, float], depth: float) -> np.ndarray:
    """Layer-frame points over and beside the face, from inside the patches to ``depth`` below."""
    x = rng.uniform(-1.3 * half[0], 1.3 * half[0], n)
    y = rng.uniform(-1.3 * half[1], 1.3 * half[1], n)
    z = 0.013 - np.exp(rng.uniform(np.log(1e-5), np.log(depth), n))
    return np.column_stack([x, y, z])


def test_point_triangle_distance_against_the_region_brute_force():
    rng = np.random.default_rng(1)
    tri = rng.normal(size=(40, 3, 3))
    p = rng.normal(scale=2, size=(50, 3))
    pairs = point_triangle_distance(p[:, None, :], tri[None]).reshape(50, 40)
    np.testing.assert_allclose(pairs, _brute_triangle(p, tri), rtol=0, atol=1e-12)
    flat = np.zeros((1, 3, 3))  # a degenerate facet: the distance to its point, not 0
    flat[0, :, 0] = 1.0
    assert point_triangle_distance(np.zeros(3), flat[0]) == pytest.approx(1.0)


@pytest.mark.parametrize("surface", [PYRAMIDS, RANDOM], ids=["pyramids", "random"])
def test_exact_against_every_facet(surface):
    """Points in the patches, in the bulk under them and beside the face, down to the depth of
    exact search: equal to the nearest of all the layer's facets to 1e-12 mm."""
    layer = _scene(surface).layers[0]
    rd = RoughSurfaceDistance(layer)
    facets = _all_facets(rd)
    q = _points(np.random.default_rng(2), 120, (0.15, 0.1), min(rd.exact_depth, 0.9))
    got = rd(layer.frame.to_world(q))
    want = _brute_triangle(q, facets).min(axis=1)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.all(rd.far_error(layer.frame.to_world(q)) == 0)


def test_deep_points_stay_within_the_stated_bound():
    """Below the exact depth the distance is the base plane's plus an offset: a lower bound,
    off by less than far_error (here under 10 nm)."""
    layer = _scene(PYRAMIDS, size=("0.3 mm", "0.2 mm", "20 mm")).layers[0]
    rd = RoughSurfaceDistance(layer)
    rng = np.random.default_rng(4)
    q = np.column_stack(
        [rng.uniform(-0.15, 0.15, 40), rng.uniform(-0.1, 0.1, 40), rng.uniform(-15, -3, 40)]
    )
    assert (q[:, 2] < rd.zlo - rd.exact_depth).all()
    world = layer.frame.to_world(q)
    got, bound = rd(world), rd.far_error(world)
    want = _brute_triangle(q, _all_facets(rd)).min(axis=1)
    assert np.all(got <= want + 1e-12)
    assert np.all(want - got <= bound + 1e-12)
    assert bound.max() < 1e-5


def test_inside_a_pyramid_on_its_axis():
    """A point on a pyramid's axis, h below its apex: distance h w / sqrt(w^2 + H^2) to its four
    faces (w half-width 5 um, H height 10 um)."""
    layer = _scene(PYRAMIDS, base="2 um").layers[0]
    rd = RoughSurfaceDistance(layer)
    w, height, base = 5e-3, 10e-3, 2e-3
    cx, cy = rd.cx[0] - 0.02, rd.cy[0] - 0.02  # the first pyramid of the first cell
    h = np.array([1e-4, 1e-3, 4e-3])
    q = np.column_stack([np.full(3, cx), np.full(3, cy), base + height - h])
    want = h * w / np.hypot(w, height)
    np.testing.assert_allclose(rd(layer.frame.to_world(q)), want, rtol=1e-12, atol=0)


def test_a_flat_rough_surface_is_the_flat_face():
    """Patches whose top is flat (two facets at height 0) on a base of 1 um: the distance is the
    flat face's, 1 um further out, for points under the face."""
    layer = _scene(PYRAMIDS).layers[0]
    half = 0.5 * np.array(layer.patch_size)
    corners = np.array(
        [
            [-half[0], -half[1], 0],
            [half[0], -half[1], 0],
            [half[0], half[1], 0],
            [-half[0], half[1], 0],
        ]
    )
    flat = SimpleNamespace(top_mesh=TriangleMesh(corners, np.array([[0, 1, 2], [0, 2, 3]])))
    fake = SimpleNamespace(
        frame=layer.frame,
        base_thickness=1e-3,
        variants=[flat],
        cell_variants=np.zeros_like(layer.cell_variants),
        patch_size=layer.patch_size,
        patch_map=layer.patch_map,
    )
    rd = RoughSurfaceDistance(fake)  # type: ignore[arg-type]
    target = layer.target
    rng = np.random.default_rng(5)
    local = np.column_stack(
        [rng.uniform(-0.14, 0.14, 200), rng.uniform(-0.09, 0.09, 200), -rng.uniform(0, 1.9, 200)]
    )
    world = target.to_world(local)
    flat_face = face_distance(target.shape, ("+z",), local)
    np.testing.assert_allclose(rd(world), flat_face + 1e-3, rtol=0, atol=1e-12)


def _write_tube(path):
    """A G4Tubs ``cyl`` (r 0.12 mm, 1 mm high) of germanium in vacuum."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 10, 10, 10, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Tubs("cyl_s", 0, 0.12, 1.0, 0, 2 * np.pi, reg)
    cyl = pg.geant4.LogicalVolume(solid, "G4_Ge", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cyl, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def test_round_face_and_the_target_surface(tmp_path):
    """Pyramids on the end face of a tube (cells inside the disc, the rest flat): the distance to
    the face is the nearest facet's (empty cells as flat squares); the distance to the whole
    surface is the smaller of that and the flat faces'."""
    data = {
        "physics": "lite",
        "world": {"gdml": str(_write_tube(tmp_path / "tube.gdml"))},
        "surfaces": {"s": PYRAMIDS},
        "targets": [
            {"volume": "cyl", "rough": [{"face": "+z", "surface": "s", "base_thickness": "1 um"}]}
        ],
        "source": {
            "particle": "alpha",
            "energy": "5 MeV",
            "surface": {"volume": "cyl", "face": "+z"},
        },
        "run": {"events": 10},
    }
    scene = build_scene(parse_config(data))
    (layer,) = scene.layers
    assert (layer.cell_variants < 0).any()
    rd = RoughSurfaceDistance(layer)
    rng = np.random.default_rng(6)
    r, phi = 0.1 * np.sqrt(rng.uniform(0, 1, 200)), rng.uniform(0, 2 * np.pi, 200)
    q = np.column_stack([r * np.cos(phi), r * np.sin(phi), 0.012 - rng.uniform(0, 0.3, 200)])
    world = layer.frame.to_world(q)
    want = _brute_triangle(q, _all_facets(rd)).min(axis=1)
    np.testing.assert_allclose(rd(world), want, rtol=0, atol=1e-12)
    distance = target_distances(scene)[0]
    inside = scene.inside_target("cyl", world)
    others = tuple(f for f in layer.target.shape.faces if f != "+z")
    flat = face_distance(layer.target.shape, others, layer.target.to_local(world))
    np.testing.assert_allclose(
        distance.to_surface(world[inside]), np.minimum(want, flat)[inside], rtol=0, atol=1e-12
    )


def test_frame_of_the_layer_is_the_faces():
    """The distance lives in the layer's frame: a face frame moved and turned gives the same
    distances to the same points moved and turned."""
    layer = _scene(PYRAMIDS).layers[0]
    rd = RoughSurfaceDistance(layer)
    q = _points(np.random.default_rng(7), 50, (0.15, 0.1), 0.1)
    turn = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    moved = SimpleNamespace(
        frame=FaceFrame(np.array([1.0, 2, 3]), turn, layer.frame.size),
        base_thickness=layer.base_thickness,
        variants=layer.variants,
        cell_variants=layer.cell_variants,
        patch_size=layer.patch_size,
        patch_map=layer.patch_map,
    )
    other = RoughSurfaceDistance(moved)  # type: ignore[arg-type]
    np.testing.assert_allclose(
        other(moved.frame.to_world(q)), rd(layer.frame.to_world(q)), rtol=0, atol=1e-12
    )
