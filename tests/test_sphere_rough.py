"""Rough layers on the curved faces of G4Orb and G4Sphere (score4.world.curved with a
score4.shapes.faces.SphereFace): patches bent onto the sphere in rings, in numpy, in Geant4 and
exported to GDML."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.source.build import layer_sampler, make_source, source_geometry
from score4.world.curved import MAX_SQUEEZE, gap_limit
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.geantinos import geantino_config, geantino_run, rough_targets
from helpers.ray_trace import mesh_path
from helpers.spawn import run_in_spawned_process

HERE = Path(__file__).parent
PYRAMIDS = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
ORB_R = 3.0  # mm
SPHERE = (2.0, 4.0, 0.2, 0.4, 1.1, 0.5)  # rmin, rmax, sphi, dphi, stheta, dtheta


def write_spheres(path: Path, orb_r: float = ORB_R) -> Path:
    """A G4Orb ``orb`` at the origin and a G4Sphere zone ``sph`` (a shell segment) at x = 15
    mm, silicon in vacuum, written by pyg4ometry."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 60, 60, 60, reg), "G4_Galactic", "W", reg)
    solids = {"orb": s.Orb("orb_s", orb_r, reg), "sph": s.Sphere("sph_s", *SPHERE, reg)}
    for (name, solid), pos in zip(solids.items(), ([0, 0, 0], [15, 0, 0]), strict=True):
        lv = pg.geant4.LogicalVolume(solid, "G4_Si", f"{name}_lv", reg)
        pg.geant4.PhysicalVolume([0, 0, 0], pos, lv, name, world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml: Path, rough: dict | None = None, **extra) -> dict:
    rough = rough or {"orb": ["outer"], "sph": ["outer", "inner"]}
    faces = ["outer", "inner"]
    return geantino_config(gdml, {"p": PYRAMIDS}, rough_targets(rough), ("sph", faces), **extra)


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    return write_spheres(tmp_path_factory.mktemp("spheres") / "spheres.gdml")


@pytest.fixture(scope="module")
def scene(gdml):
    return build_scene(parse_config(config(gdml)))


def test_bent_layers_follow_the_sphere(scene):
    """Every bent body lies on or outside the true sphere (outer faces) or inside the cavity
    (the inner face), within the layer; the measured gap is under the limit; the orb's polar
    caps, where a patch would be squeezed by more than MAX_SQUEEZE, stay flat."""
    for layer in scene.layers:
        assert isinstance(layer, CurvedRoughLayer)
        lay = layer.ring_layout
        assert layer.gap <= gap_limit(10e-3)
        for j in np.flatnonzero(lay.count > 0)[:: max(1, len(lay.v) // 5)]:
            body = layer.bent(0, int(j))
            h = lay.face.locate(body.vertices + np.array([0.0, 0.0, lay.ring_z(int(j))]))[2]
            assert h.min() >= -1e-12
            assert h.max() <= layer.thickness
    orb = scene.layer("orb", "outer")
    lay = orb.ring_layout
    held = lay.count > 0
    py = orb.patch_size[1]
    inner = np.minimum(lay.face.radius(lay.v - py / 2), lay.face.radius(lay.v + py / 2))
    assert (inner[held] >= (1 - MAX_SQUEEZE) * lay.radius[held]).all()
    assert not held.all()  # the caps
    assert 0.9 < orb.rough_share < 1.0


def test_samples_lie_on_the_bent_tops_and_the_flat_rest(gdml, scene):
    """A source on both curved faces of the shell: every point in the target or its layers,
    the flat share as the uncovered area's share of the true area (4 sigma)."""
    cfg = parse_config(config(gdml))
    p = make_source(cfg, scene).primaries(np.random.default_rng(2), 0, 4000)
    assert scene.inside_target("sph", p.position).all()
    geo = source_geometry(cfg, scene)
    layers = scene.layers_of("sph")
    flat_area = sum(la.face_area * (1 - la.rough_share) for la in layers)
    tops = sum(layer_sampler(la).area for la in layers)
    assert geo["area_mm2"] == pytest.approx(tops + flat_area, rel=1e-9)
    share = flat_area / geo["area_mm2"]
    on_flat = p.extra["patch"] < 0
    assert abs(on_flat.mean() - share) < 4 * math.sqrt(share * (1 - share) / 4000)


def orb_path(o: np.ndarray, d: np.ndarray, layer, radius: float = ORB_R) -> float:
    """Independent ray trace: the chord of the analytic orb (of ``radius``) plus the path in
    the bent patch bodies of the cells near where the ray crosses the sphere."""
    b = o @ d
    c = o @ o - radius**2
    disc = b * b - c
    total = 0.0
    lay = layer.ring_layout
    if disc <= 0:
        return 0.0
    t1, t2 = -b - math.sqrt(disc), -b + math.sqrt(disc)
    total += t2 - t1
    px, py = layer.patch_size
    for t in (t1, t2):
        _, v0, _ = lay.face.locate((o + t * d)[None])
        phi0 = math.atan2((o + t * d)[1], (o + t * d)[0])
        tri_all = []
        for j in np.flatnonzero((np.abs(lay.v - v0[0]) < 3 * py) & (lay.count > 0)):
            r = lay.radius[j]
            for i, phi in enumerate(lay.cell_phi(int(j))):
                dphi = (phi - phi0 + math.pi) % (2 * math.pi) - math.pi
                if abs(dphi) * r > 3 * px:
                    continue
                body = layer.bent(int(layer.cell_variants[j, i]), int(j))
                cs, sn = math.cos(phi), math.sin(phi)
                v = body.vertices @ np.array([[cs, sn, 0], [-sn, cs, 0], [0, 0, 1]])
                tri_all.append((v + np.array([0.0, 0.0, lay.ring_z(int(j))]))[body.faces])
        if tri_all:
            for tri in tri_all:
                total += mesh_path(o, d, tri)
    return total


@pytest.mark.parametrize("solid", ["frustums", "tessellated"])
def test_geantino_paths_agree_with_an_independent_ray_trace(gdml, scene, tmp_path, solid):
    """Geantinos from outside the orb's layer through the rough sphere (both crossings):
    Geant4's track length in the orb (its patches count) equals the ray trace of the analytic
    sphere plus the bent patch meshes, to 1e-9 mm: with the patches as bent G4Traps and
    G4GenericTraps in G4Sphere cells (``solid: auto`` for spike grids) and as bent tessellated
    bodies."""
    data = config(gdml, {"orb": ["outer"]}, output={"track_length": True})
    data["targets"][0]["rough"][0]["solid"] = solid
    data["source"]["surface"] = {"volume": "orb", "face": "outer"}
    cfg = parse_config(data)
    own = build_scene(cfg)
    layer = own.layer("orb", "outer")
    assert layer.solid_kind(0) == solid
    rng = np.random.default_rng(7)
    n = 30
    lay = layer.ring_layout
    rows = np.flatnonzero(lay.count > 0)
    starts, directions = [], []
    for _ in range(n):
        j = int(rng.choice(rows))
        phi = float(rng.choice(lay.cell_phi(j))) + rng.uniform(-0.3, 0.3) * lay.step[j]
        p = lay.face.point(phi, lay.v[j] + rng.uniform(-0.03, 0.03))
        start = p * (ORB_R + 0.05) / ORB_R
        aim = rng.uniform(-1.5, 1.5, 3)
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    primaries = make_source(cfg, own).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    got = np.asarray(r.scores["track_length"]["orb"])
    expected = np.array([orb_path(o, d, layer) for o, d in zip(starts, directions, strict=True)])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    assert (expected > 2 * ORB_R * 0.1).all()


def test_bent_traps_on_the_sphere_are_the_bent_bodies(scene):
    """On a sphere each spike (and the block of slab below it) bent onto a ring is exactly a
    G4Trap or G4GenericTrap: their corners are the bent corners of the mesh (1e-12 mm); the
    body's floor (two triangles per spike cell, the blocks' planar floors) stays off the face
    and the measured gap under the limit."""
    from score4.geometry.curved import bent_corners, bent_traps

    for name, face in (("orb", "outer"), ("sph", "outer"), ("sph", "inner")):
        layer = scene.layer(name, face)
        assert layer.solid_kind(0) == "frustums"
        grid = layer.variants[0].spikes
        f = grid.frustums()
        box = {"x": f["x"], "y": f["y"], "z0": f["z"] - f["height"] / 2}
        box |= {"z1": f["z"] + f["height"] / 2, "wxb": f["width_x_bottom"]}
        box |= {"wxt": f["width_x_top"], "wyb": f["width_y_bottom"], "wyt": f["width_y_top"]}
        lay = layer.ring_layout
        held = np.flatnonzero(lay.count > 0)
        for j in (int(held[0]), int(held[len(held) // 2]), int(held[-1])):
            traps = bent_traps(layer, j, box, np.asarray(f["spike"]))
            bottom, top = bent_corners(layer, j, box)
            order = [0, 1, 3, 2, 4, 5, 7, 6]  # G4Trap's corner order from bent_corners'
            moved = np.abs(traps.vertices - np.concatenate([bottom, top], axis=1)[:, order])
            assert moved.max() <= 1e-12
            body = layer.bent(0, j)
            h = lay.face.locate(body.vertices + np.array([0.0, 0.0, lay.ring_z(j)]))[2]
            assert h.min() >= -1e-12  # the floor's corners at the lift, nothing below the face
    assert scene.layer("orb", "outer").gap <= gap_limit(10e-3)


def _call(name, *args):
    sys.path.insert(0, str(HERE))
    from helpers import g4_gdml_world

    return getattr(g4_gdml_world, name)(*args)


@pytest.mark.parametrize("into", [False, pytest.param(True, marks=pytest.mark.deep)])
def test_exported_sphere_layers_give_the_same_geantino_paths(gdml, scene, tmp_path, into):
    """The shell segment with both curved faces rough (``into``: grown into the shell, which
    is thinner), written to GDML by `score4 geometry export` and read back by Geant4: the same
    ray paths (volumes and points, 1e-9 mm)."""
    cfg = tmp_path / "sph.yaml"
    data = config(gdml, {"sph": ["outer", "inner"]})
    for r in data["targets"][0]["rough"]:
        r["into"] = into
    cfg.write_text(yaml.safe_dump(data))
    scene = build_scene(parse_config(data)) if into else scene
    out = tmp_path / "world.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(5)
    rays = []
    for face in ("outer", "inner"):
        layer = scene.layer("sph", face)
        lay = layer.ring_layout
        target = layer.target
        for _ in range(4):
            j = int(rng.choice(np.flatnonzero(lay.count > 0)))
            phi = float(rng.choice(lay.cell_phi(j)))
            p = lay.face.point(phi, lay.v[j]) + 0.03 * lay.face.normal(phi, lay.v[j])
            inward = -lay.face.normal(phi, lay.v[j]) + rng.uniform(-0.2, 0.2, 3)
            rays.append((target.to_world(p[None])[0].tolist(), inward.tolist()))
    ours = run_in_spawned_process(_call, "trace_built", str(cfg), rays)
    back = run_in_spawned_process(_call, "trace_gdml", str(out), rays)
    for a, b in zip(ours, back, strict=True):
        assert len(a) == len(b)
        np.testing.assert_allclose([p for _, p in a], [p for _, p in b], atol=1e-9, rtol=0)
    assert min(len(a) for a in ours) > 4  # the rays cross the envelope, cells and spikes


def test_a_face_the_orb_lacks_lists_its_faces(gdml):
    with pytest.raises(
        ConfigError, match=r"no face 'inner' on a G4Orb; its faces: outer; groups: all"
    ):
        build_scene(parse_config(config(gdml, {"orb": ["inner"]})))


def test_an_orb_too_small_for_the_patch_states_the_radius_needed(tmp_path):
    gdml = write_spheres(tmp_path / "small.gdml", orb_r=0.5)
    data = config(gdml, {"orb": ["outer"]})
    data["surfaces"]["p"] = {
        "kind": "spikes",
        "nx": 1,
        "ny": 1,
        "width": "100 um",
        "height": "2 um",
    }
    with pytest.raises(ConfigError, match=r"curved too tightly .* radius >= [\d.]+ mm"):
        build_scene(parse_config(data))


def test_steps_on_a_rough_sphere_face_are_refused_before_anything_runs(gdml):
    data = config(gdml)
    data["output"] = {**data.get("output", {}), "steps": True}
    with pytest.raises(ConfigError, match="rough sphere face; steps"):
        build_scene(parse_config(data))


def test_into_the_orb_cuts_it_and_keeps_the_paths(gdml, tmp_path):
    """into: true on the orb's face: the orb is made smaller by the layer's thickness, the
    layer's top lies on the old sphere; points of the cut shell count only in a patch; Geant4's
    geantino track lengths equal the ray trace of the smaller sphere plus the bent patches to
    1e-9 mm. The shell's faces take into too."""
    data = config(gdml, {"orb": ["outer"]}, output={"track_length": True})
    data["targets"][0]["rough"][0]["into"] = True
    data["source"]["surface"] = {"volume": "orb", "face": "outer"}
    cfg = parse_config(data)
    own = build_scene(cfg)
    layer = own.layer("orb", "outer")
    lay = layer.ring_layout
    radius = lay.face.sphere_radius
    assert radius + layer.thickness == pytest.approx(ORB_R, abs=1e-12)
    assert layer.thickness == pytest.approx(11e-3, rel=1e-3)
    rng = np.random.default_rng(9)
    shell = rng.normal(size=(4000, 3))  # points in the cut shell, radius - thickness .. radius
    depth = rng.uniform(1e-6, layer.thickness - 1e-6, 4000)
    shell *= ((radius + depth) / np.linalg.norm(shell, axis=1))[:, None]
    np.testing.assert_array_equal(own.inside_target("orb", shell), layer.contains(shell))
    assert own.inside_target("orb", shell * (radius - 1e-6) / ORB_R).all()
    rows = np.flatnonzero(lay.count > 0)
    n = 20
    starts, directions = [], []
    for _ in range(n):
        j = int(rng.choice(rows))
        phi = float(rng.choice(lay.cell_phi(j))) + rng.uniform(-0.3, 0.3) * lay.step[j]
        p = lay.face.point(phi, lay.v[j] + rng.uniform(-0.03, 0.03))
        start = p * (ORB_R + 0.05) / radius
        aim = rng.uniform(-1.5, 1.5, 3)
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    primaries = make_source(cfg, own).primaries(np.random.default_rng(1), 0, n)
    assert own.inside_target("orb", primaries.position).all()
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    got = np.asarray(r.scores["track_length"]["orb"])
    expected = [orb_path(o, d, layer, radius) for o, d in zip(starts, directions, strict=True)]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    both = config(gdml, {"sph": ["outer", "inner"]})
    for r in both["targets"][0]["rough"]:
        r["into"] = True
    shells = build_scene(parse_config(both))
    outer, inner = shells.layer("sph", "outer"), shells.layer("sph", "inner")
    assert outer.ring_layout.face.sphere_radius + outer.thickness == pytest.approx(4.0, abs=1e-12)
    assert inner.ring_layout.face.sphere_radius - inner.thickness == pytest.approx(2.0, abs=1e-12)
