"""Steps and activeness on a layer that grows a subtracted solid (``into: true`` on the floor of
a conical blind hole, score4.world.boolean_modes): a small Geant4 run on a copper box less a
G4Cons whose ``dist_to_surf`` and ``active_edep`` match a brute force over the patch tops of
the floor's cells (helpers.into_steps.brute_rough), the box's faces and the
hole's wall (1e-9)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.activeness import weight
from score4.world.resolve import build_scene

from helpers.into_steps import PYRAMIDS, brute_rough, into_steps_run

HALF = 10.0  # the box's half width, mm
HEX = np.radians(30.0 + 60.0 * np.arange(6))  # the hexagon's side directions


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """20 mm copper boxes less a cone (``cone``: r 2 mm at its floor, 5 mm below the box's top,
    widening to 3 mm 5 mm above it) and less a hexagonal G4Polyhedra (``hedra``: apothem 2 mm
    at its floor widening to 3 mm, at y = 30 mm) along z."""
    from helpers.boolean_worlds import write_box_holes

    def holes(s, reg) -> dict:
        cone = s.Cons("cone_b", 0, 2, 0, 3, 10, 0, 2 * np.pi, reg)
        hedra = s.Polyhedra("hedra_b", 0, 2 * np.pi, 6, 2, [-5, 5], [0, 0], [2, 3], reg)
        return {"cone": (cone, [0.0, 0.0, HALF], 0.0), "hedra": (hedra, [0.0, 0.0, HALF], 30.0)}

    return write_box_holes(tmp_path_factory.mktemp("grown_distance") / "cone.gdml", holes, HALF)


def wall_distance(p: np.ndarray, top: float = 15.0) -> np.ndarray:
    """Distance of points (box frame) to the cone's wall, r = 2 mm at z = 5 mm widening by
    0.1 mm per mm up to z = ``top`` (the whole wall ends at 15 mm; the uncut wall: the layer
    grows the cone only under its floor)."""
    rho, z = np.hypot(p[:, 0], p[:, 1]), p[:, 2]
    a, b = np.array([2.0, 5.0]), np.array([2.0 + 0.1 * (top - 5.0), top])
    d = b - a
    s = np.clip(((rho - a[0]) * d[0] + (z - a[1]) * d[1]) / (d @ d), 0.0, 1.0)
    return np.hypot(rho - a[0] - s * d[0], z - a[1] - s * d[1])


def floor_distance(p: np.ndarray, t: float) -> np.ndarray:
    """Distance of points (box frame) below the grown floor's level (z = 5 mm - t) to its disk
    (r 2 mm - 0.1 t); 0 above that level (no bound there)."""
    rho = np.hypot(p[:, 0], p[:, 1])
    d = np.hypot(np.maximum(rho - (2.0 - 0.1 * t), 0.0), 5.0 - t - p[:, 2])
    return np.where(p[:, 2] <= 5.0 - t, d, 0.0)


def _activeness_scene(gdml: Path, volume: str, face: str, **sections):
    """The scene of ``volume`` with ``into`` pyramids on ``face`` and an activeness entry
    listing that face (plus the configuration ``sections`` given), and the volume's activeness
    distances."""
    from score4.world.activeness import target_distances

    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [
            {
                "volume": volume,
                "rough": [{"face": face, "surface": "p", "into": True}],
                "activeness": [{"fccd": "1 mm", "dlf": 0.5, "faces": [face]}],
            }
        ],
        "source": {"particle": "geantino", "energy": "1 MeV", "volume": volume},
        "run": {"events": 1, "seed": 1},
        **sections,
    }
    scene = build_scene(parse_config(data))
    (distance,) = [d for d in target_distances(scene) if d is not None]
    return scene, distance


def _patch_tops(layer) -> np.ndarray:
    """Every top facet (n, 3, 3) of the layer's kept cells, in the layer's frame (each variant's
    top mesh moved to its cell and lifted by the base)."""
    cells = np.asarray(layer.cell_variants)
    centres = layer.cell_centres()
    tops = [
        np.asarray(layer.variants[k].top_mesh.vertices, float)[
            np.asarray(layer.variants[k].top_mesh.faces)
        ]
        + np.array([*centres[j, i], layer.base_thickness])
        for j, i in zip(*np.nonzero(cells >= 0), strict=True)
        for k in [cells[j, i]]
    ]
    return np.concatenate(tops) if tops else np.empty((0, 3, 3))


def test_steps_and_activeness_on_a_grown_cone_floor(gdml, tmp_path):
    """Alphas from the pyramids on the hole's floor (into: true: the cone grown 21 um down),
    30 events, seed 13, a 3 um transition layer under the floor and a 1 mm one along the wall:
    each step's dist_to_surf is the nearest of the brute-force rough surface, the box's faces
    and the wall, to 1e-9 mm (the rough surface below the floor's level at least as far as the
    floor's disk); steps in the slab under the old floor are in patches; active_edep weights
    each step by the brute-force distances (1e-9 MeV)."""
    cfg, res, evtid, edep, world, dist = into_steps_run(
        gdml, "cone", "second.-z", ("second.outer", "1 mm"), 13, tmp_path
    )
    scene = build_scene(cfg)
    layer = scene.layer("cone", "second.-z")
    t = layer.thickness
    target = scene.target("cone")
    p = target.to_local(world)
    assert target.to_local(layer.frame.centre[None])[0, 2] == pytest.approx(5.0 - t, abs=1e-12)
    in_patch = layer.contains(world)
    rho = np.hypot(p[:, 0], p[:, 1])
    slab = (p[:, 2] > 5.0 - t) & (p[:, 2] < 5.0) & (rho < 2.0 - 0.1 * t)
    assert slab.sum() > 20
    assert in_patch[slab].all()  # the grown cone under the old floor: vacuum but for patches
    # the floor's layer lies over its disk: below its level no nearer than the disk (its flat
    # cells beside the disk's column are not surface)
    rough = np.maximum(brute_rough(layer, world), floor_distance(p, t))
    box = np.min(HALF - np.abs(p), axis=1)
    wall = wall_distance(p)
    # the 3 x 3 cells hold every point of the rough surface nearer than a cell's width; steps
    # farther (on the wall, alphas cross the hole) are nearer to the wall or the box
    far = rough >= min(layer.patch_size)
    assert (np.minimum(box, wall)[far] < min(layer.patch_size)).all()
    assert (~far).sum() > 100
    np.testing.assert_allclose(dist, np.minimum(np.minimum(rough, box), wall), rtol=0, atol=1e-9)
    under = ~in_patch & (rough < np.minimum(box, wall))
    assert under.sum() > 10  # in the copper under the floor
    near_wall = wall_distance(p, top=HALF)  # the wall as it is on the box: z = 5 .. 10 mm
    assert (near_wall < 1.0).sum() > 5  # steps the wall's entry weights
    surface = np.minimum(np.minimum(rough, box), wall)
    w = np.minimum(
        weight(np.maximum(surface, rough), 3e-3, 0.5),
        weight(np.maximum(surface, near_wall), 1.0, 0.2),
    )
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["cone"], atol=1e-9, rtol=0)
    assert 0 < again.sum() < res.edep["cone"].sum()


def test_distances_to_the_six_grown_sides_of_a_polyhedra(gdml):
    """``into`` on the six sides of a subtracted G4Polyhedra (one face, a layer per plane):
    the distance of points in the copper behind each side, 30 um to 0.4 mm deep, is the nearest
    of the six layers' rough surfaces (brute force over each layer's patch tops), the hole's
    floor (a hexagon of triangles, some of them of no area at its centre) and the box's faces,
    1e-9 mm; the activeness distance to the sides alone is the same. (Before, the last plane's
    layer alone was measured, and the floor's triangles of no area were at distance 0 from
    every point.)"""

    scene, distance = _activeness_scene(gdml, "hedra", "second.seg_1", output={"steps": True})
    layers = scene.layers_of("hedra")
    assert len(layers) == 6
    rng = np.random.default_rng(4)
    n = 120
    a = np.radians(30.0 + 60.0 * rng.integers(0, 6, n))  # the sides' directions
    z = rng.uniform(5.5, 9.5, n)  # box frame: the hole from z = 5 mm up through the top
    apothem = (
        2.0 + 0.1 * (z - 5.0) + layers[0].thickness * np.sqrt(1.01) + rng.uniform(0.03, 0.4, n)
    )
    along = rng.uniform(-0.8, 0.8, n)
    local = np.column_stack(
        [apothem * np.cos(a) - along * np.sin(a), apothem * np.sin(a) + along * np.cos(a), z]
    )
    world = scene.target("hedra").to_world(local)
    rough = np.min([brute_rough(layer, world) for layer in layers], axis=0)
    assert rough.max() < min(layers[0].patch_size)  # the 3 x 3 cells hold the nearest points
    rho = np.max(np.outer(local[:, 0], np.cos(HEX)) + np.outer(local[:, 1], np.sin(HEX)), axis=1)
    floor = np.hypot(np.maximum(rho - 2.0, 0.0), z - 5.0)  # the floor: apothem <= 2 mm, z = 5
    box = np.min(HALF - np.abs(local), axis=1)
    expected = np.minimum(np.minimum(rough, floor), box)
    np.testing.assert_allclose(distance.to_surface(world), expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(distance.to_faces(("second.seg_1",), world), rough, atol=1e-9)


def test_activeness_distance_beside_a_grown_floor(gdml):
    """The activeness distance to the grown cone floor and the whole surface's (its layer a
    square grid over the disk, the cells off the disk flat squares in the copper): beside the
    floor's column and below its level, the distance to the disk's rim (closed form, 1e-6 mm,
    the rim's chords), not to the flat squares (up to 0.8 mm nearer), or to the wall or box
    if nearer; over the disk, the brute-force rough surface."""

    scene, distance = _activeness_scene(gdml, "cone", "second.-z")
    layer = scene.layer("cone", "second.-z")
    t = layer.thickness
    rng = np.random.default_rng(2)
    n = 400
    rho = rng.uniform(0.2, 3.5, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    local = np.column_stack(
        [rho * np.cos(phi), rho * np.sin(phi), 5.0 - t - rng.uniform(0, 0.4, n)]
    )
    world = scene.target("cone").to_world(local)
    got = distance.to_faces(("second.-z",), world)
    beside = rho > 2.0 - 0.1 * t
    assert beside.sum() > 100
    np.testing.assert_allclose(got[beside], floor_distance(local, t)[beside], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[~beside], brute_rough(layer, world[~beside]), atol=1e-9)
    others = np.minimum(np.min(HALF - np.abs(local), axis=1), wall_distance(local))
    expected = np.minimum(floor_distance(local, t), others)
    np.testing.assert_allclose(
        distance.to_surface(world)[beside], expected[beside], rtol=0, atol=1e-6
    )
    assert (brute_rough(layer, world[beside]) < got[beside] - 0.1).sum() > 20  # the old bound


def _into_rest(q: np.ndarray, lo: np.ndarray, hi: np.ndarray, centre, r: float) -> np.ndarray:
    """Nearest points (2D) of the convex set square [lo, hi] ∩ disk(centre, r) to points ``q``
    (n, 2), by Dykstra's alternating projections (an independent method)."""
    x, p, s = q.copy(), np.zeros_like(q), np.zeros_like(q)
    for _ in range(400):
        y = np.clip(x + p, lo, hi)
        p = x + p - y
        v = y + s - centre
        norm = np.linalg.norm(v, axis=1)
        z = centre + v * np.minimum(1.0, r / np.maximum(norm, 1e-300))[:, None]
        s = y + s - z
        x = z
    return x


def test_activeness_distance_over_a_grown_floor_is_exact(gdml):
    """The activeness distance to the grown cone floor (its layer a square grid over the disk,
    cells off the disk flat squares in the copper) at points in the volume from 0.1 mm below
    the floor's level up through its patches and beside them, rho 0.2 .. 2.6 mm: the nearest of
    every patch top facet and of the flat rest (the disk r 2 mm - 0.1 t less the patch cells:
    per flat cell, its square cut by the disk, a convex set, projected onto by Dykstra's
    method), to 1e-6 mm (the disk rim's chords). The whole-layer bound (flat cells off the disk
    counted) raised to the level's distance below it (before) is more than 2 um too near at
    some points."""
    from score4.shapes.mesh_shape import _tri_distance

    scene, distance = _activeness_scene(gdml, "cone", "second.-z")
    layer = scene.layer("cone", "second.-z")
    target = scene.target("cone")
    t = layer.thickness
    rng = np.random.default_rng(21)
    m = 1200
    rho, phi = rng.uniform(0.2, 2.6, m), rng.uniform(0, 2 * np.pi, m)
    z = 5.0 - t + rng.uniform(-0.1, t, m)
    world = target.to_world(np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z]))
    world = world[distance.to_surface(world) > 0][:400]  # in the copper or a patch
    got = distance.to_faces(("second.-z",), world)
    # brute force in the layer's frame (z = 0: the grown floor's level)
    q = layer.frame.to_local(world)
    cells = np.asarray(layer.cell_variants)
    centres = layer.cell_centres()
    half = np.array(layer.patch_size) / 2
    patch = _tri_distance(q, _patch_tops(layer)).min(axis=1)
    axis = layer.frame.to_local(target.to_world(np.array([[0.0, 0.0, 5.0 - t]])))[0]
    assert abs(axis[2]) < 1e-12
    r = 2.0 - 0.1 * t
    rest = np.full(len(q), np.inf)
    for j, i in zip(*np.nonzero(cells < 0), strict=True):
        lo, hi = centres[j, i] - half, centres[j, i] + half
        if np.linalg.norm(np.clip(axis[:2], lo, hi) - axis[:2]) >= r:
            continue  # the cell is off the disk
        x = _into_rest(q[:, :2], lo, hi, axis[:2], r)
        assert np.abs(np.clip(x, lo, hi) - x).max() < 1e-9  # converged onto the square too
        rest = np.minimum(rest, np.hypot(np.linalg.norm(q[:, :2] - x, axis=1), q[:, 2]))
    expected = np.minimum(patch, rest)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6)
    old = distance.boolean._beside(
        "second.-z", world, target.to_local(world), distance.rough_distance("second.-z")(world)
    )
    assert (expected - old > 2e-3).sum() > 10  # the bound before: flat cells off the disk


def _nearest_in(q: np.ndarray, lo: np.ndarray, hi: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """Nearest points (2D) to ``q`` (n, 2) of the squares [lo, hi] (n, 2) cut by the half-planes
    ``planes`` (k, 3: n . x <= d), row by row, by Dykstra's cyclic projections."""
    x = q.copy()
    parts = [np.zeros_like(x) for _ in range(len(planes) + 1)]
    for _ in range(600):
        y = x + parts[0]
        z = np.clip(y, lo, hi)
        parts[0], x = y - z, z
        for k, (nx, ny, d) in enumerate(planes, start=1):
            y = x + parts[k]
            over = np.maximum(y[:, 0] * nx + y[:, 1] * ny - d, 0.0) / (nx * nx + ny * ny)
            z = y - over[:, None] * np.array([nx, ny])
            parts[k], x = y - z, z
    return x


def test_activeness_distance_to_the_six_grown_sides_is_exact(gdml):
    """The activeness distance to the six grown sides of the subtracted G4Polyhedra (a layer
    per plane, each a square grid whose flat cells reach past its side, beside the hexagon's
    corners and over the box's top) at points in the copper behind the sides, along them up to
    and past the corners: the nearest over the six layers of every patch top facet and of the
    flat rest (per flat cell, its square cut by the side as it is on the box at the grown level,
    a convex polygon: Dykstra's projections), to 1e-6 mm. The whole layers (before) are more
    than 2 um too near at some of them."""
    from scipy.spatial import ConvexHull

    from score4.shapes.mesh_shape import _tri_distance
    from score4.world.facets import face_triangles

    scene, distance = _activeness_scene(gdml, "hedra", "second.seg_1")
    layers = scene.layers_of("hedra")
    target = scene.target("hedra")
    rng = np.random.default_rng(22)
    m = 600
    a = np.radians(30.0 + 60.0 * rng.integers(0, 6, m))
    z = rng.uniform(5.2, 9.9, m)
    apothem = 2.0 + 0.1 * (z - 5.0) + layers[0].thickness * 1.01 + rng.uniform(0.0, 0.15, m)
    along = rng.uniform(-2.0, 2.0, m)
    local = np.column_stack(
        [apothem * np.cos(a) - along * np.sin(a), apothem * np.sin(a) + along * np.cos(a), z]
    )
    world = target.to_world(local)
    world = world[distance.to_surface(world) > 0][:150]
    got = distance.to_faces(("second.seg_1",), world)
    best = np.full(len(world), np.inf)
    for layer in layers:  # the patch tops
        tops = _patch_tops(layer)
        if len(tops):
            best = np.minimum(best, _tri_distance(layer.frame.to_local(world), tops).min(axis=1))
    for layer in layers:  # the flat rest: each flat cell cut by the side at the grown level
        on = layer.on_boolean
        q = layer.frame.to_local(world)
        cells = np.asarray(layer.cell_variants)
        centres = layer.cell_centres()
        half = np.array(layer.patch_size) / 2
        # the side in this layer's plane, as it is on the box (z <= 10 mm)
        tri = face_triangles(on.clip.leaf, on.clip.face).reshape(-1, 3)
        v = layer.frame.to_local(on.transform.apply(on.clip.transform.apply(tri)))
        v = v[np.abs(v[:, 2]) < 1e-9][:, :2]
        planes = [(e[0], e[1], -e[2]) for e in ConvexHull(v).equations]
        at = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        h = target.to_local(layer.frame.to_world(at))[:, 2]  # box z over the plane: linear
        planes.append((h[1] - h[0], h[2] - h[0], HALF - h[0]))
        flat = np.argwhere(cells < 0)
        lo = centres[flat[:, 0], flat[:, 1]] - half
        hi = centres[flat[:, 0], flat[:, 1]] + half
        # the pairs (point, cell) whose square alone is nearer than the best so far
        e = np.maximum(np.maximum(lo[None] - q[:, None, :2], q[:, None, :2] - hi[None]), 0.0)
        row, col = np.nonzero(np.hypot(np.linalg.norm(e, axis=2), q[:, None, 2]) < best[:, None])
        x = _nearest_in(q[row, :2], lo[col], hi[col], np.array(planes))
        inside = (np.abs(np.clip(x, lo[col], hi[col]) - x) < 1e-9).all(axis=1)
        for nx, ny, d in planes:  # cells the side does not reach: empty
            inside &= x[:, 0] * nx + x[:, 1] * ny <= d + 1e-9
        d = np.hypot(np.linalg.norm(x - q[row, :2], axis=1), q[row, 2])
        np.minimum.at(best, row[inside], d[inside])
    np.testing.assert_allclose(got, best, rtol=0, atol=1e-6)
    old = distance.boolean._beside(
        "second.seg_1",
        world,
        target.to_local(world),
        distance.rough_distance("second.seg_1")(world),
    )
    assert (best - old > 2e-3).sum() > 5  # the whole layers: flat cells off the side
