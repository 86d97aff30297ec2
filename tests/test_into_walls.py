"""``into: true`` on the walls of G4Tubs, G4Cons and polycones: the solid is cut by the layer's
thickness along the wall's normal and the bent layer takes its place (score4.world.scene,
score4.shapes.revolved.offset_contour)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from test_curved_rough import (
    HALF_Z,
    RADIUS,
    cylinder_config,
    ray_path,
    write_cone,
    write_cylinder,
)

from score4.cli.main import main
from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.shapes import G4Cons, G4GenericPolycone, G4Polycone, G4Tubs
from score4.source.build import make_source, source_geometry
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_run
from helpers.ray_trace import patches_path, revolved_path
from helpers.spawn import run_in_spawned_process


@pytest.fixture(scope="module")
def cylinder(tmp_path_factory):
    return write_cylinder(tmp_path_factory.mktemp("cyl") / "cyl.gdml")


@pytest.fixture(scope="module")
def cone(tmp_path_factory):
    return write_cone(tmp_path_factory.mktemp("cone") / "cone.gdml")


def into_config(gdml, face="outer", **extra):
    data = cylinder_config(gdml, face=face, output={"track_length": True}, **extra)
    data["targets"][0]["rough"][0]["into"] = True
    return data


def test_cut_solids_keep_their_type_and_move_the_wall_along_its_normal():
    """A tube's wall moves in radius; a cone's radii at both ends move by t sqrt(1 + slope^2),
    so the wall moves by t along its normal; a cone closing to a point gets shorter; a
    polycone segment moves with its neighbours' lines kept (the shared corners slide along
    them); a neighbour shorter than the cut's reach is refused with its name."""
    tube, shift = G4Tubs(1.0, 2.0, 1.0).trimmed({"outer": 0.1, "inner": 0.2})
    assert tube == G4Tubs(1.2, 1.9, 1.0)
    assert not shift.any()
    cone, shift = G4Cons(0.0, 3.0, 0.0, 4.0, 1.0).trimmed({"outer": 0.01})
    assert isinstance(cone, G4Cons)
    assert cone.rmax1 == pytest.approx(3.0 - 0.01 * math.sqrt(1.25), abs=1e-15)
    assert cone.rmax2 == pytest.approx(4.0 - 0.01 * math.sqrt(1.25), abs=1e-15)
    assert cone.dz == 1.0
    assert not shift.any()
    # the distance of the moved wall from the old one, along the normal
    n = np.array([2.0, -1.0]) / math.sqrt(5)
    assert (np.array([cone.rmax1, -1.0]) - np.array([3.0, -1.0])) @ n == pytest.approx(-0.01)
    point, shift = G4Cons(0.0, 3.0, 0.0, 0.0, 1.0).trimmed({"outer": 0.01})
    assert isinstance(point, G4Cons)
    assert point.rmax2 == 0.0
    apex = 1.0 - 0.01 * math.hypot(3.0, 2.0) / 3.0  # the moved wall meets the axis lower
    assert point.dz + shift[2] == pytest.approx(apex, abs=1e-12)
    assert point.dz - shift[2] == pytest.approx(1.0, abs=1e-12)
    poly = G4Polycone(0.0, 2 * math.pi, (0.0, 1.0, 2.0), (1.0, 1.0, 1.5), (3.0, 3.5, 3.5))
    cut, shift = poly.trimmed({"seg_2": 0.1})  # the vertical outer wall from z = 1 to 2
    assert isinstance(cut, G4GenericPolycone)
    assert not shift.any()
    corners = np.column_stack([cut.r, cut.z])
    # seg_1 (r 3 -> 3.5 over z 0 -> 1) meets the moved wall r = 3.4 at z = 0.8; seg_3 (the top)
    np.testing.assert_allclose(corners[2], [3.4, 0.8], atol=1e-12)
    np.testing.assert_allclose(corners[3], [3.4, 2.0], atol=1e-12)
    assert cut.volume == pytest.approx(
        poly.volume - 2 * math.pi * (1.0 * (3.5**2 - 3.4**2) / 2 + 0.5 * 0.1 * 0.2 * 3.4333333),
        rel=1e-3,
    )
    with pytest.raises(ConfigError, match=r"leaves no face seg_1 \(1\.118 mm long\)"):
        poly.trimmed({"seg_2": 0.6})


def test_into_a_tube_wall_cuts_it_and_keeps_the_paths(cylinder, tmp_path):
    """into on a G4Tubs' outer wall: the layer's top lies on the old radius; points of the cut
    shell count only in a patch; sources on the face sample the bent tops and the flat rest of
    the cut wall with their areas; the target's volume (Geant4's, after the cut) is the tube
    less the shell; geantino track lengths equal the ray trace of the thinner cylinder plus the
    bent patches to 1e-9 mm."""
    data = into_config(cylinder)
    config = parse_config(data)
    scene = build_scene(config)
    (layer,) = scene.layers
    lay = layer.ring_layout
    radius = float(lay.face.radius(0.0))
    assert radius + layer.thickness == pytest.approx(RADIUS, abs=1e-12)
    assert layer.thickness == pytest.approx(11e-3, rel=1e-3)
    rng = np.random.default_rng(4)
    phi, z = rng.uniform(0, 2 * np.pi, 4000), rng.uniform(-0.9, 0.9, 4000)
    r = radius + rng.uniform(1e-6, layer.thickness - 1e-6, 4000)
    shell = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    np.testing.assert_array_equal(scene.inside_target("cyl", shell), layer.contains(shell))
    assert 0.3 < layer.contains(shell).mean() < 0.9  # pyramids fill a third, the slab more
    inner = np.column_stack([(radius - 1e-6) * np.cos(phi), (radius - 1e-6) * np.sin(phi), z])
    assert scene.inside_target("cyl", inner).all()
    # sources: the bent tops (mesh area) and the rest of the cut wall (its own, smaller area)
    geo = source_geometry(config, scene)
    top = layer.bent(0, 0).top_triangles
    bent_area = (
        0.5 * np.linalg.norm(np.cross(top[:, 1] - top[:, 0], top[:, 2] - top[:, 0]), axis=1).sum()
    )
    cells = lay.n_cells
    wall = 2 * math.pi * radius * 2 * HALF_Z
    assert geo["area_mm2"] == pytest.approx(cells * bent_area + wall - cells * 0.01, rel=1e-9)
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 2000)
    assert scene.inside_target("cyl", p.position).all()
    rho = np.hypot(p.position[:, 0], p.position[:, 1])
    assert rho.max() <= RADIUS + 1e-9  # inside the old envelope
    assert (rho > radius + layer.base_thickness - 1e-9).mean() > 0.99  # on the tops
    # geantinos from outside through the rough wall, the cylinder and the far wall
    n = 30
    phi = rng.uniform(0, 2 * np.pi, n)
    start = np.column_stack(
        [(RADIUS + 0.1) * np.cos(phi), (RADIUS + 0.1) * np.sin(phi), rng.uniform(-0.3, 0.3, n)]
    )
    aim = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-0.3, 0.3, n)])
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    p = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    res = geantino_run(data, p, start, direction, tmp_path)
    expected = ray_path(start, direction, layer, radius, HALF_Z)
    np.testing.assert_allclose(res.scores["track_length"]["cyl"], expected, rtol=0, atol=1e-9)
    (vol,) = res.run["volumes"]
    own = vol["volume_mm3"] - vol["layer_volume_mm3"]
    assert own == pytest.approx(math.pi * radius**2 * 2 * HALF_Z, rel=1e-9)


def test_into_a_cone_wall_cuts_it_and_keeps_the_paths(cone, tmp_path):
    """The same on a G4Cons' side (radius 3 to 4 mm over 2 mm): the cut cone's radii move by
    t sqrt(1 + 0.5^2), the layer's top lies on the old cone, the volume is Geant4's of the
    cut G4Cons, and the geantino paths equal the ray trace of the cut cone plus the bent
    patches to 1e-9 mm."""
    data = into_config(cone)
    config = parse_config(data)
    scene = build_scene(config)
    (layer,) = scene.layers
    face = layer.ring_layout.face
    t = layer.thickness
    # the moved face lies t from the old one along the normal, parallel to it
    old = scene.targets[0].shape.face("outer")
    for end in (face.rz1, face.rz2):  # on the old line when moved back by t
        back = np.asarray(end) + t * np.asarray(face.nrz) - np.asarray(old.rz1)
        assert back @ np.asarray(old.nrz) == pytest.approx(0.0, abs=1e-12)
    assert face.rz1[1] == -1.0
    assert face.rz2[1] == 1.0
    assert face.nrz == pytest.approx(old.nrz, abs=1e-15)
    r0 = 3.5 - t * math.sqrt(1.25)  # the cut cone's radius at z = 0
    rng = np.random.default_rng(7)
    n = 40  # the rays of test_curved_rough's cone test: all cross the wall, not the ends
    p = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    assert scene.inside_target("cyl", p.position).all()
    phi = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(-0.3, 0.3, n)
    r = 3.5 + 0.5 * z + 0.1
    start = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    aim = np.column_stack(
        [rng.uniform(-1.5, 1.5, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-0.3, 0.3, n)]
    )
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    res = geantino_run(data, p, start, direction, tmp_path)
    expected = ray_path(start, direction, layer, r0, 1.0, slope=0.5)
    assert (expected > 1.0).all()
    np.testing.assert_allclose(res.scores["track_length"]["cyl"], expected, rtol=0, atol=1e-9)
    (vol,) = res.run["volumes"]
    r1, r2 = r0 - 0.5, r0 + 0.5
    cut = math.pi * 2.0 / 3 * (r1 * r1 + r1 * r2 + r2 * r2)
    assert vol["volume_mm3"] - vol["layer_volume_mm3"] == pytest.approx(cut, rel=1e-9)


def test_bad_into_walls_are_one_line_errors(cylinder, tmp_path, capsys):
    """A tube thinner than the layer, and two into faces sharing an edge: one line, exit 2."""
    thin = write_cylinder(tmp_path / "thin.gdml", rmin=RADIUS - 0.005)
    data = into_config(thin)
    with pytest.raises(
        ConfigError,
        match=r"into: the layer \(11 um\) on face outer of 'cyl': G4Tubs: a cut of 11 um "
        r"behind face outer leaves no wall: the tube is 5 um thick",
    ):
        build_scene(parse_config(data))

    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["run", str(path), "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "leaves no wall" in err[0]
    assert not (tmp_path / "o.h5").exists()


def write_polycone(
    path, z=(0.0, 1.0, 2.0), rmin=(1.0, 1.0, 1.5), rmax=(3.0, 3.5, 3.5), dphi=2 * math.pi
):
    """A G4Polycone ``cyl`` of silicon in vacuum (by default a cone piece from r 3 to 3.5 mm
    over z 0 to 1, then a cylinder of r 3.5 mm to z 2, a bore of r 1 to 1.5 mm)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    world = pg.geant4.LogicalVolume(
        pg.geant4.solid.Box("world_s", 200, 200, 200, reg), "G4_Galactic", "World", reg
    )
    solid = pg.geant4.solid.Polycone("cyl_s", 0, dphi, list(z), list(rmin), list(rmax), reg)
    lv = pg.geant4.LogicalVolume(solid, "G4_Si", "Cyl", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "cyl", world, reg)
    reg.setWorld(world.name)
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def test_into_a_polycone_segment(tmp_path):
    """into on seg_1 of a G4Polycone (the cone piece): the cut solid is a G4GenericPolycone
    with only that segment moved (its neighbours' lines kept), Geant4's volume of it is the
    contour's, the layer's top lies on the old segment and sources on it stay in the volume;
    a segment whose neighbour is shorter than the cut's reach is a one-line error."""
    gdml = write_polycone(tmp_path / "pc.gdml")
    data = into_config(gdml, face="seg_1", run={"events": 20, "seed": 3})
    config = parse_config(data)
    scene = build_scene(config)
    (layer,) = scene.layers
    shape = scene.targets[0].shape
    cut, _shift = layer.cut_shape
    assert isinstance(cut, G4GenericPolycone)
    old, new = shape.face("seg_1"), layer.ring_layout.face
    back = np.asarray(new.rz1) + layer.thickness * np.asarray(new.nrz) - np.asarray(old.rz1)
    assert back @ np.asarray(old.nrz) == pytest.approx(0.0, abs=1e-12)
    assert new.rz1[1] == 0.0  # on the bottom's line; the other end on seg_2's line r = 3.5
    assert new.rz2[0] == 3.5
    assert new.rz2[1] > 1.0
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 500)
    assert scene.inside_target("cyl", p.position).all()
    res = read_results(run(config, tmp_path / "o.h5", progress=False, echo=lambda m: None))
    (vol,) = res.run["volumes"]
    assert vol["volume_mm3"] - vol["layer_volume_mm3"] == pytest.approx(cut.volume, rel=1e-6)
    short = write_polycone(tmp_path / "short.gdml", z=(0.0, 0.004, 2.0), rmax=(3.0, 3.002, 3.5))
    with pytest.raises(ConfigError, match=r"leaves no face seg_1 \(0\.004\d* mm long\)"):
        build_scene(parse_config(into_config(short, face="seg_2")))


def _call(name, *args):
    sys.path.insert(0, str(Path(__file__).parent))
    from helpers import g4_gdml_world

    return getattr(g4_gdml_world, name)(*args)


@pytest.mark.deep
@pytest.mark.parametrize("faces", ["seg_1", ["seg_0", "seg_1", "seg_2", "seg_3"]])
def test_exported_polycone_into_world_gives_the_same_geantino_paths(tmp_path, faces):
    """The polycone cut for into on seg_1, and on four neighbouring faces (their joint cut), a
    G4GenericPolycone read from its own small GDML file, and the layers, written by `score4
    geometry export` and read back by Geant4: the same ray paths through seg_1's layer
    (volumes and points, 1e-9 mm)."""
    gdml = write_polycone(tmp_path / "pc.gdml")
    data = into_config(gdml, face=faces)
    cfg = tmp_path / "pc.yaml"
    cfg.write_text(yaml.safe_dump(data))
    scene = build_scene(parse_config(data))
    out = tmp_path / "world.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    assert "<genericPolycone" in out.read_text()
    rng = np.random.default_rng(5)
    layer = scene.layer("cyl", "seg_1")
    lay = layer.ring_layout
    rays = []
    for _ in range(6):
        j = int(rng.choice(np.flatnonzero(lay.count > 0)))
        phi = float(rng.choice(lay.cell_phi(j)))
        p = lay.face.point(phi, lay.v[j]) + 0.03 * lay.face.normal(phi, lay.v[j])
        inward = -lay.face.normal(phi, lay.v[j]) + rng.uniform(-0.2, 0.2, 3)
        rays.append((layer.target.to_world(p[None])[0].tolist(), inward.tolist()))
    ours = run_in_spawned_process(_call, "trace_built", str(cfg), rays)
    back = run_in_spawned_process(_call, "trace_gdml", str(out), rays)
    for a, b in zip(ours, back, strict=True):
        assert len(a) == len(b)
        np.testing.assert_allclose([p for _, p in a], [p for _, p in b], atol=1e-9, rtol=0)
    assert min(len(a) for a in ours) > 4  # the rays cross the envelope, cells and spikes


def test_into_clears_a_sister_the_layer_outside_would_meet(tmp_path):
    """A copper cube 5 um from the tube's wall: the 11 um layer outside runs into it (refused,
    naming the gap); cut into the wall, the layer stays in the old envelope and passes."""
    gdml = write_cylinder(tmp_path / "sister.gdml", sister=0.005)
    outside = into_config(gdml)
    outside["targets"][0]["rough"][0]["into"] = False
    with pytest.raises(ConfigError, match=r"runs into sister volume 'cube' \(free gap there: 5 um"):
        build_scene(parse_config(outside))
    (layer,) = build_scene(parse_config(into_config(gdml))).layers
    assert float(layer.ring_layout.face.radius(0.0)) + layer.thickness == pytest.approx(RADIUS)


def test_into_a_tube_wall_and_end_face_together(cylinder, tmp_path):
    """into on the wall and the +z face of a tube: the joint cut is a G4Tubs thinner by the
    wall's layer and shorter by the end's; the wall's layer lies on the shortened wall, the end
    face's cells and flat rest within the ring the wall's cut leaves; sources on both faces
    stay in the volume; Geant4's volume is the cut tube's and geantino paths through the wall
    equal the ray trace of the thinner cylinder plus the bent patches to 1e-9 mm."""
    data = into_config(cylinder)
    data["targets"][0]["rough"].append({"face": "+z", "surface": "p", "into": True})
    data["source"]["surface"]["face"] = ["outer", "+z"]
    config = parse_config(data)
    scene = build_scene(config)
    wall, end = scene.layer("cyl", "outer"), scene.layer("cyl", "+z")
    face = wall.ring_layout.face
    radius = float(face.radius(0.0))
    assert radius + wall.thickness == pytest.approx(RADIUS, abs=1e-12)
    assert face.rz1[1] == -HALF_Z
    assert face.rz2[1] == pytest.approx(HALF_Z - end.thickness, abs=1e-12)
    assert end.rest_radii == (0.0, radius)
    centres = end.patch_map.cell_centres()[end.mask]
    far = np.hypot(np.abs(centres[:, 0]) + 0.05, np.abs(centres[:, 1]) + 0.05)
    assert far.max() <= radius
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 2000)
    assert scene.inside_target("cyl", p.position).all()
    n = 30
    rng = np.random.default_rng(7)
    phi = rng.uniform(0, 2 * np.pi, n)
    start = np.column_stack(
        [(RADIUS + 0.1) * np.cos(phi), (RADIUS + 0.1) * np.sin(phi), rng.uniform(-0.3, 0.3, n)]
    )
    aim = np.column_stack(  # nearly level: the rays leave through the far wall, not the ends
        [rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), start[:, 2] + rng.uniform(-0.1, 0.1, n)]
    )
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    p = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    res = geantino_run(data, p, start, direction, tmp_path)
    expected = ray_path(start, direction, wall, radius, HALF_Z)
    np.testing.assert_allclose(res.scores["track_length"]["cyl"], expected, rtol=0, atol=1e-9)
    (vol,) = res.run["volumes"]
    own = vol["volume_mm3"] - vol["layer_volume_mm3"]
    assert own == pytest.approx(math.pi * radius**2 * (2 * HALF_Z - end.thickness), rel=1e-9)


def joint_paths(scene, start, direction):
    """Independent trace of rays through a target cut for several into layers: the path in the
    joint cut solid (analytic, its contour's cones and planes) plus the paths in every layer's
    patch meshes."""
    target = scene.targets[0]
    cuts = {layer.config.face_name: layer.thickness for layer in scene.layers}
    cut, shift = target.shape.trimmed(cuts)
    out = np.zeros(len(start))
    for k, (o, d) in enumerate(zip(start, direction, strict=True)):
        out[k] = revolved_path(target.to_local(o[None])[0] - shift, d @ target.rotation, cut)
        out[k] += sum(patches_path(o, d, layer, 20.0) for layer in scene.layers)
    return out, cut


def edge_rays(rng, corners, centre, n):
    """``n`` rays from a sphere of 8 mm about ``centre`` (outside the solid and its layers) to
    points within 50 um of the contour corners ``corners`` ((r, z) pairs), turned at random
    about the axis."""
    rz = np.asarray(corners, float)[rng.integers(0, len(corners), n)]
    rz += rng.uniform(-0.05, 0.05, (n, 2))
    phi = rng.uniform(0, 2 * np.pi, n)
    aim = np.column_stack([rz[:, 0] * np.cos(phi), rz[:, 0] * np.sin(phi), rz[:, 1]])
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    start = np.asarray(centre) + 8.0 * u
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    return start, direction


def _check_joint_run(data, config, scene, start, direction, tmp_path, volume_rel: float) -> None:
    """Geantinos along the rays through a joint cut: paths as traced (1e-9 mm), most rays inside
    the cut solid, and Geant4's volume less the layers' equal to the cut solid's."""
    n = len(start)
    p = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    res = geantino_run(data, p, start, direction, tmp_path)
    expected, cut = joint_paths(scene, start, direction)
    assert (expected > 0).sum() > n // 2
    np.testing.assert_allclose(res.scores["track_length"]["cyl"], expected, rtol=0, atol=1e-9)
    (vol,) = res.run["volumes"]
    assert vol["volume_mm3"] - vol["layer_volume_mm3"] == pytest.approx(cut.volume, rel=volume_rel)


def test_into_on_neighbouring_polycone_segments(tmp_path):
    """into on four neighbouring faces of a G4Polycone (the bottom ring, the cone piece, the
    cylinder wall, the top ring): every layer lies on its face of the joint cut (each face moved
    inward by its layer, its neighbours' moved lines kept), the walls meeting at the moved
    corner, the rings' cells and flat rest within the joint cut's faces; sources on all four
    stay in the volume; Geant4's volume of the cut G4GenericPolycone is the joint contour's, and
    geantino paths through the edges equal the trace of the joint cut plus every layer's
    patches to 1e-9 mm."""
    gdml = write_polycone(tmp_path / "pc.gdml")
    faces = ["seg_0", "seg_1", "seg_2", "seg_3"]
    data = into_config(gdml, face=faces)
    data["source"]["surface"]["face"] = faces
    config = parse_config(data)
    scene = build_scene(config)
    layers = {f: scene.layer("cyl", f) for f in faces}
    shape = scene.targets[0].shape
    cuts = {f: layer.thickness for f, layer in layers.items()}
    joint = shape.cut_contour(cuts)[0]
    for f in ("seg_1", "seg_2"):
        wall = layers[f].ring_layout.face
        k = int(f[-1])
        np.testing.assert_allclose([wall.rz1, wall.rz2], joint[[k, k + 1]], atol=1e-12)
    np.testing.assert_allclose(joint[2], [3.5 - cuts["seg_2"], 1.0 + 0.0024], atol=2e-4)
    bottom, top = layers["seg_0"], layers["seg_3"]
    assert bottom.rest_radii == pytest.approx((1.0, joint[1, 0]), abs=1e-12)
    assert top.rest_radii == pytest.approx((joint[4, 0], joint[3, 0]), abs=1e-12)
    assert top.ring == pytest.approx((1.5, 3.5), abs=1e-12)  # the bore widens up: r >= 1.5
    for ring in (bottom, top):
        lo, hi = max(ring.rest_radii[0], ring.ring[0]), min(ring.rest_radii[1], ring.ring[1])
        centres = ring.patch_map.cell_centres()[ring.mask]
        far = np.hypot(np.abs(centres[:, 0]) + 0.05, np.abs(centres[:, 1]) + 0.05)
        near = np.hypot(np.maximum(np.abs(centres[:, 0]) - 0.05, 0), np.abs(centres[:, 1]) - 0.05)
        assert far.max() <= hi + 1e-12
        assert near.min() >= lo - 1e-12
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 3000)
    assert scene.inside_target("cyl", p.position).all()
    n = 24
    start, direction = edge_rays(np.random.default_rng(3), joint[:4], (0, 0, 1), n)
    _check_joint_run(data, config, scene, start, direction, tmp_path, volume_rel=1e-6)


def test_into_a_cone_wall_and_its_end_faces(tmp_path):
    """into on a G4Cons' side (radius 3 to 4 mm over 2 mm) and both end faces: the joint cut is
    a G4Cons; the wall's layer ends on the end faces' cut planes; each end face's envelope is
    the ring the old cone fills over the whole slab (at +z the wall leans in over it: r <= 4 -
    t/2), its cells within that and the joint cut's face, its flat rest on the joint cut's
    face; sources stay in the volume; Geant4's volume and geantino paths through the edges
    (trace of the cut cone plus every layer's patches, 1e-9 mm)."""
    from test_curved_rough import write_cone

    gdml = write_cone(tmp_path / "cone.gdml")
    faces = ["outer", "+z", "-z"]
    data = into_config(gdml, face=faces)
    data["source"]["surface"]["face"] = faces
    config = parse_config(data)
    scene = build_scene(config)
    wall, top, bottom = (scene.layer("cyl", f) for f in faces)
    cuts = {f: scene.layer("cyl", f).thickness for f in faces}
    cut, _shift = scene.targets[0].shape.trimmed(cuts)
    assert isinstance(cut, G4Cons)
    face = wall.ring_layout.face
    assert face.rz1 == pytest.approx((cut.rmax1, -1.0 + cuts["-z"]), abs=1e-12)
    assert face.rz2 == pytest.approx((cut.rmax2, 1.0 - cuts["+z"]), abs=1e-12)
    assert top.ring == pytest.approx((0.0, 4.0 - cuts["+z"] / 2), abs=1e-12)
    assert bottom.ring == (0.0, 3.0)
    assert top.rest_radii == pytest.approx((0.0, cut.rmax2), abs=1e-12)
    assert bottom.rest_radii == pytest.approx((0.0, cut.rmax1), abs=1e-12)
    p = make_source(config, scene).primaries(np.random.default_rng(2), 0, 3000)
    assert scene.inside_target("cyl", p.position).all()
    n = 24
    start, direction = edge_rays(np.random.default_rng(4), [(4.0, 1.0), (3.0, -1.0)], (0, 0, 0), n)
    _check_joint_run(data, config, scene, start, direction, tmp_path, volume_rel=1e-9)


def test_into_on_shared_edges_of_a_phi_segment_is_one_line(tmp_path, capsys):
    """A polycone with a phi segment: into on two neighbouring segments is refused in one line
    (exit 2, nothing written), as is into on a phi face of a tube; into on one wall of either
    is laid out."""
    gdml = write_polycone(tmp_path / "half.gdml", dphi=math.pi)
    with pytest.raises(
        ConfigError,
        match=r"into: true on faces seg_1 and seg_2 of 'cyl', which share an edge \(the circle "
        r"r = 3.5 mm at z = 1 mm\), on a G4GenericPolycone with a phi segment",
    ):
        build_scene(parse_config(into_config(gdml, face=["seg_1", "seg_2"])))
    (layer,) = build_scene(parse_config(into_config(gdml, face="seg_2"))).layers
    assert layer.ring_layout.face.dphi == pytest.approx(math.pi)
    tube = write_cylinder(tmp_path / "tube.gdml", dphi=math.pi)
    path = tmp_path / "bad.yaml"
    for world, faces in ((gdml, ["seg_1", "seg_2"]), (tube, ["outer", "phi_start"])):
        path.write_text(yaml.safe_dump(into_config(world, face=faces)))
        assert main(["run", str(path), "--out", str(tmp_path / "o.h5")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        assert "into: true on face" in err[0]
    assert not (tmp_path / "o.h5").exists()
