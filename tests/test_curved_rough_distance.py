"""Distances to the rough surface of a curved rough layer (bent patches on a cylinder wall,
score4.world.rough_distance.CurvedRoughSurfaceDistance) against a brute force over every bent
facet, an analytic flat-topped layer, and a small Geant4 run's step table."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from test_activeness import _run
from test_curved_rough import cylinder_config, write_cylinder
from test_rough_distance import _brute_triangle

from score4.inputs.config import parse_config
from score4.runner.output import read_results
from score4.world.activeness import face_distance, weight
from score4.world.resolve import build_scene
from score4.world.rough_distance import CurvedRoughSurfaceDistance, _Variant
from score4.world.scene import CurvedRoughLayer

RADIUS, HALF_Z = 0.5, 0.05  # mm: two rings of 50 um patches
SMALL = {"kind": "spikes", "nx": 5, "ny": 5, "width": "10 um", "height": "10 um"}


@pytest.fixture(scope="module")
def tube(tmp_path_factory):
    return write_cylinder(tmp_path_factory.mktemp("tube") / "tube.gdml", RADIUS, HALF_Z)


def _layer(tube) -> CurvedRoughLayer:
    (layer,) = build_scene(parse_config(cylinder_config(tube, surface=SMALL))).layers
    assert isinstance(layer, CurvedRoughLayer)
    return layer


def _every_bent_facet(layer: CurvedRoughLayer) -> np.ndarray:
    """Every bent top facet of the layer in the target's frame, placed cell by cell."""
    lay = layer.ring_layout
    out = []
    for j, _i, k, phi in layer.cells():
        assert k >= 0  # spikes fill every cell
        tri = layer.bent(k, j).top_triangles.copy()
        tri[..., 2] += lay.ring_z(j)
        c, s = np.cos(phi), np.sin(phi)
        x, y = tri[..., 0].copy(), tri[..., 1].copy()
        tri[..., 0], tri[..., 1] = c * x - s * y, s * x + c * y
        out.append(tri)
    return np.concatenate(out)


def _points(n: int, h: tuple[float, float], rng) -> np.ndarray:
    """Points at heights h (mm) above the wall, anywhere around it, within the rings' z."""
    phi = rng.uniform(-np.pi, np.pi, n)
    r = RADIUS + rng.uniform(*h, n)
    z = rng.uniform(-0.045, 0.045, n)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def test_curved_distance_is_the_nearest_bent_facet(tube):
    """Points in the bulk under the wall (down to 40 um) and in the patches' shell: the distance
    equals the brute force over all ~12 000 bent facets to 1e-12 mm."""
    layer = _layer(tube)
    rd = CurvedRoughSurfaceDistance(layer)
    assert rd.exact_depth > 0.04  # all these points are in the exact range
    rng = np.random.default_rng(5)
    local = np.vstack([_points(60, (-0.04, 0.0), rng), _points(120, (0.0, 0.012), rng)])
    world = layer.target.to_world(local)
    inside = layer.contains(world)
    assert inside.sum() > 10  # some of them inside the pyramids
    facets = _every_bent_facet(layer)
    assert len(facets) > 10_000
    brute = _brute_triangle(local, facets).min(axis=1)
    got = rd(world)
    np.testing.assert_allclose(got, brute, rtol=0, atol=1e-12)
    assert got[inside].max() > 1e-3  # micrometres inside a pyramid, not 0
    assert np.all(rd.far_error(world) == 0.0)  # exact here


def test_flat_topped_curved_layer_is_the_smooth_wall_plus_its_base(tube):
    """Patch tops made flat (a fine 11 x 11 grid at height 0, bent like the real ones): points
    under the wall are at the smooth wall's distance plus the base thickness and lift, to the
    sagitta of the bent facets (< 1e-5 mm); deeper than the exact range (forced), the same
    exactly (the smooth wall's distance plus the tops' lowest level)."""
    layer = _layer(tube)
    rd = CurvedRoughSurfaceDistance(layer)
    lay = layer.ring_layout
    px, py = lay.patch_size
    g = np.linspace(-0.5, 0.5, 11)
    x, y = np.meshgrid(g * px, g * py, indexing="ij")
    flat = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    quads = [
        (a * 11 + b, (a + 1) * 11 + b, (a + 1) * 11 + b + 1, a * 11 + b + 1)
        for a in range(10)
        for b in range(10)
    ]
    faces = np.array([t for q in quads for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))])
    offset = layer.base_thickness + layer.lift
    for j in range(len(lay.v)):
        key = (0, layer.ring_solid_key(j))
        rd._variants[key] = _Variant(lay.bend(flat, j, offset), faces, 0.0)
        v = rd._variants[key].tri.reshape(-1, 3)
        centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
        rd._reach[key] = (centre, float(np.linalg.norm(v - centre, axis=1).max()))
    rd.zlo = offset
    rng = np.random.default_rng(8)
    phi = rng.uniform(-np.pi / 2, np.pi / 2, 80) + lay.phi_mid  # away from the ring's gap
    r = RADIUS - rng.uniform(0.0, 0.3, 80)
    local = np.column_stack([r * np.cos(phi), r * np.sin(phi), rng.uniform(-0.04, 0.04, 80)])
    world = layer.target.to_world(local)
    smooth = face_distance(layer.target.shape, ("outer",), local)
    np.testing.assert_allclose(rd(world), smooth + offset, rtol=0, atol=1e-5)
    rd.exact_depth = 0.0  # every point under the tops now takes the far branch
    np.testing.assert_allclose(rd(world), smooth + offset, rtol=0, atol=1e-12)


def test_steps_on_a_rough_cylinder_wall_measure_the_rough_surface(tmp_path_factory, tube):
    """Alphas from the pyramid tops on the tube's wall: dist_to_surf is the distance to the
    bent tops (or the smooth end caps, if nearer), not 0 in the pyramids, and active_edep
    weights the steps by it."""
    data = cylinder_config(
        tube,
        surface=SMALL,
        source={
            "particle": "alpha",
            "energy": "5 MeV",
            "surface": {"volume": "cyl", "face": "outer"},
        },
    )
    data["targets"][0]["activeness"] = [{"fccd": "3 um", "dlf": 0.5, "faces": ["outer"]}]
    data["run"]["events"] = 30
    data["output"] = {"steps": True}
    out = _run(tmp_path_factory, "curved", data)
    res = read_results(out)
    scene = build_scene(parse_config(data))
    (layer,) = scene.layers
    with h5py.File(out, "r") as f:
        g = f[f"stp/{scene.targets[0].name}"]
        points = np.column_stack([g[c][()] * 1e3 for c in ("xloc", "yloc", "zloc")])
        evtid, edep, dist = g["evtid"][()], g["edep"][()] / 1e3, g["dist_to_surf"][()] * 1e3
    assert len(points) > 100
    in_patch = layer.contains(points)
    assert in_patch.sum() > 0.2 * len(points)
    rough = CurvedRoughSurfaceDistance(layer)(points)
    target = layer.target
    caps = tuple(f for f in target.shape.faces if f != "outer")
    smooth = face_distance(target.shape, caps, target.to_local(points))
    np.testing.assert_allclose(dist, np.minimum(rough, smooth), rtol=0, atol=1e-12)
    assert dist[in_patch].max() > 1e-3
    under = ~in_patch & (smooth > rough)
    assert under.sum() > 10
    r = np.hypot(*target.to_local(points[under])[:, :2].T)
    # at least the base (and lift) further than the smooth wall was
    assert np.all(rough[under] >= RADIUS - r + layer.base_thickness - 1e-9)
    w = weight(rough, 3e-3, 0.5)
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    column = scene.targets[0].name
    np.testing.assert_allclose(again, res.scores["active_edep"][column], atol=1e-12, rtol=0)


def _write_cone(path):
    """A G4Cons ``cyl`` of silicon (radius 0.5 -> 0.4 mm over 0.2 mm) in vacuum."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Cons("cyl_s", 0, 0.5, 0, 0.4, 0.2, 0, 2 * np.pi, reg)
    cone = pg.geant4.LogicalVolume(solid, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], cone, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


@pytest.mark.parametrize("case", ["cone", "bore", "partial"])
def test_cones_bores_and_partial_walls_match_the_brute_force(tmp_path, case):
    """A cone's side (rings of different radii), a tube's bore (a concave face) and a wall of
    3 rad: points under, in and above the patches, also beyond the face's phi range, against the
    brute force over every bent facet to 1e-12 mm."""
    if case == "cone":
        path, face = _write_cone(tmp_path / "cone.gdml"), "outer"
    elif case == "bore":
        path, face = write_cylinder(tmp_path / "b.gdml", 0.8, 0.05, rmin=0.5, dphi=3.0), "inner"
    else:
        path, face = write_cylinder(tmp_path / "p.gdml", 0.5, 0.05, dphi=3.0), "outer"
    (layer,) = build_scene(parse_config(cylinder_config(path, face=face, surface=SMALL))).layers
    assert isinstance(layer, CurvedRoughLayer)
    lay = layer.ring_layout
    rng = np.random.default_rng(1)
    (u0, u1), (v0, v1) = lay.face.extent
    u, v = rng.uniform(u0 - 0.2, u1 + 0.2, 150), rng.uniform(v0, v1, 150)
    h = rng.uniform(-0.05, 0.012, 150)
    local = lay.face.point(u, v) + h[:, None] * lay.face.normal(u, v)
    brute = _brute_triangle(local, _every_bent_facet(layer)).min(axis=1)
    got = CurvedRoughSurfaceDistance(layer)(layer.target.to_world(local))
    np.testing.assert_allclose(got, brute, rtol=0, atol=1e-12)


def test_a_cell_without_patch_is_the_smooth_wall_there(tube):
    """A cell emptied by hand (-1): a point over or under its middle is at its height from the
    smooth wall, nearer than any facet of the neighbouring patches."""
    layer = _layer(tube)
    rd = CurvedRoughSurfaceDistance(layer)
    rd.cells = rd.cells.copy()
    rd.cells[1, 7] = -1
    lay = layer.ring_layout
    phi, v = lay.cell_phi(1)[7], lay.v[1]
    h = np.array([0.002, -0.01])
    local = lay.face.point(phi, v) + h[:, None] * lay.face.normal(phi, v)
    got = rd(layer.target.to_world(local))
    np.testing.assert_allclose(got, np.abs(h), rtol=0, atol=1e-12)
    facets = _every_bent_facet(layer)
    assert np.all(_brute_triangle(local, facets).min(axis=1) > np.abs(h) + 1e-4)
