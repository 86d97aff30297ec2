"""What a rough layer on a boolean solid's face does besides its geometry
(score4.world.boolean_distance and boolean_layers): steps (remage's layout) and activeness on
the copper box less a tube of tests/helpers/boolean_worlds.py, against distances written here
from the solid's dimensions."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.world.activeness import target_distances, volume_activeness, weight
from score4.world.resolve import build_scene
from score4.world.rough_distance import CurvedRoughSurfaceDistance, RoughSurfaceDistance

from helpers.geantinos import geantino_config

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high (0.4 mm for the 5 mm bore)
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
FINE = {**PYRAMIDS, "width": "80 um"}
HALF, BORE = 10.0, 5.0  # the box's half width and the bore's radius, mm (boolean_worlds)
STACK = (0.0, -30.0, 0.0)  # where the union stands


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """The copper box less a tube of tests/helpers/boolean_worlds.py (a 20 mm box less a tube
    of r 5 mm, 40 mm long, along z, at the origin) and its union of two tubes (a disk of r 10 mm,
    10 mm high, with a post of r 7 mm on it, at ``STACK``), written by pyg4ometry."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 100, 100, 100, reg), "G4_Galactic", "W", reg)
    box = s.Box("cut_a", 2 * HALF, 2 * HALF, 2 * HALF, reg)
    hole = s.Tubs("cut_b", 0, BORE, 40, 0, 2 * np.pi, reg)
    cut = s.Subtraction("cutbox_s", box, hole, [[0, 0, 0], [0, 0, 0]], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "cutbox_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "cutbox", world, reg)
    disk = s.Tubs("stack_a", 0, 10, 10, 0, 2 * np.pi, reg)  # with a post on it: a union
    post = s.Tubs("stack_b", 0, 7, 10, 0, 2 * np.pi, reg)
    stack = s.Union("stack_s", disk, post, [[0, 0, 0], [0, 0, 10]], reg)
    lv = pg.geant4.LogicalVolume(stack, "G4_Cu", "stack_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], list(STACK), lv, "stack", world, reg)
    reg.setWorld(world.name)
    path = tmp_path_factory.mktemp("modes") / "cutbox.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml: Path, rough: list[dict], **extra) -> dict:
    targets = [{"volume": "cutbox", "rough": rough}]
    surfaces = {"p": PYRAMIDS, "fine": FINE}
    return geantino_config(gdml, surfaces, targets, ("cutbox", "first.+z"), **extra)


def _rect(p: np.ndarray, lo, hi) -> np.ndarray:
    """Distance of points to the axis-aligned box [lo, hi] (a face: one side of zero width)."""
    e = np.maximum(np.maximum(np.asarray(lo) - p, p - np.asarray(hi)), 0.0)
    return np.sqrt((e * e).sum(axis=1))


def box_faces(p: np.ndarray, faces: list[str]) -> np.ndarray:
    """Exact distance of points (the cutbox's frame: its origin) to the listed faces of the
    20 mm box, each a whole square."""
    out = np.full(len(p), np.inf)
    for f in faces:
        axis, sign = "xyz".index(f[1]), 1.0 if f[0] == "+" else -1.0
        lo, hi = np.full(3, -HALF), np.full(3, HALF)
        lo[axis] = hi[axis] = sign * HALF
        out = np.minimum(out, _rect(p, lo, hi))
    return out


def tube_ends(p: np.ndarray) -> np.ndarray:
    """Distance to the end disks (r 5 mm, z = +-20 mm) of the subtracted tube."""
    r = np.hypot(p[:, 0], p[:, 1])
    return np.hypot(np.maximum(r - BORE, 0.0), 20.0 - np.abs(p[:, 2]))


def test_activeness_on_a_smooth_boolean_face_is_its_distance(gdml):
    """Without a rough layer: the distance to face first.+z of the box less the tube is
    10 - z, to first.+x 10 - x (it was infinite, every deposit fully active), to the whole
    surface the nearest of the box's faces and the bore; outside the solid 0."""
    data = config(gdml, [])
    data["targets"][0]["activeness"] = [{"fccd": "1 mm", "dlf": 0.5, "faces": ["first.+z"]}]
    scene = build_scene(parse_config(data))
    (act,) = volume_activeness(scene)
    assert act is not None
    rng = np.random.default_rng(5)
    p = rng.uniform(-HALF, HALF, (4000, 3))
    p = p[np.hypot(p[:, 0], p[:, 1]) > BORE]
    world = scene.target("cutbox").to_world(p)
    d = act.distance
    np.testing.assert_allclose(d.to_faces(("first.+z",), world), HALF - p[:, 2], atol=1e-12)
    np.testing.assert_allclose(d.to_faces(("first.+x",), world), HALF - p[:, 0], atol=1e-12)
    whole = np.minimum(HALF - np.abs(p).max(axis=1), np.hypot(p[:, 0], p[:, 1]) - BORE)
    np.testing.assert_allclose(d.to_surface(world), whole, atol=1e-12)
    np.testing.assert_allclose(d.to_faces(("first.+z", "second.outer"), world),
                               np.minimum(HALF - p[:, 2], np.hypot(p[:, 0], p[:, 1]) - BORE),
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(act.weights(world), weight(HALF - p[:, 2], 1.0, 0.5), atol=1e-12)
    hole = scene.target("cutbox").to_world(np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 11.0]]))
    assert (d.to_faces(("first.+z",), hole) == 0).all()


def test_distances_to_a_rough_bore_and_face(gdml):
    """The bore's wall and the +z face around it rough: the distance of points in the copper
    near both, and in the bore's patches, is the nearest of the bore's rough surface, the +z
    face's rough surface and the other faces, each measured whole (exact here)."""
    rough = [{"face": "second.outer", "surface": "fine"}, {"face": "first.+z", "surface": "p"}]
    scene = build_scene(parse_config(config(gdml, rough, output={"steps": True})))
    target = scene.target("cutbox")
    (distance,) = target_distances(scene)
    assert distance is not None
    bore, top = scene.layer("cutbox", "second.outer"), scene.layer("cutbox", "first.+z")
    rng = np.random.default_rng(7)
    n = 2500
    phi = rng.uniform(0, 2 * np.pi, n)
    z = np.concatenate([rng.uniform(-9.9, 10, n // 2), rng.uniform(9.97, 10.025, n - n // 2)])
    r = np.concatenate(
        [rng.uniform(BORE - 0.03, BORE + 0.1, n // 2), rng.uniform(BORE, BORE + 1.5, n - n // 2)]
    )
    p = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    world = target.to_world(p)
    in_bore, in_top = bore.contains(world), top.contains(world)
    material = (r > BORE) & (z < HALF)
    keep = material | in_bore | in_top
    p, world, in_bore, in_top = p[keep], world[keep], in_bore[keep], in_top[keep]
    assert in_bore.sum() > 30
    assert in_top.sum() > 3
    expected = np.minimum.reduce(
        [
            CurvedRoughSurfaceDistance(bore)(world),
            RoughSurfaceDistance(top)(world),
            box_faces(p, ["+x", "-x", "+y", "-y", "-z"]),
            tube_ends(p),
        ]
    )
    got = distance.to_surface(world)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert (got[in_bore] > 0).all()  # in the bore's patches: in the copper, not 0
    assert (got[~(in_bore | in_top)] > 0).all()
    # under the bore's patches, deeper than the smooth wall (the 1 um base at least)
    deep = (np.hypot(p[:, 0], p[:, 1]) > BORE) & (got < 0.01) & (np.abs(p[:, 2]) < 9)
    assert deep.sum() > 10
    assert (got[deep] >= np.hypot(p[deep, 0], p[deep, 1]) - BORE + 1e-3 - 1e-12).all()
    away = target.to_world(np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 30.0]]))
    assert (distance.to_surface(away) == 0).all()


def test_steps_and_activeness_on_a_rough_boolean_face(gdml, tmp_path):
    """Alphas from the pyramids on the +z face of the box less the tube, with steps and a 3 um
    transition layer under that face: the steps add up to each event's deposit; each step's
    dist_to_surf (remage's layout, read by legend-lh5io) is the nearest of the face's rough
    surface and the box's other faces and the bore; active_edep weights the deposits by the
    distance to the rough face."""
    import lh5

    data = config(gdml, [{"face": "first.+z", "surface": "p", "base_thickness": "1 um"}])
    data["targets"][0]["activeness"] = [{"fccd": "3 um", "dlf": 0.5, "faces": ["first.+z"]}]
    data["source"] = {
        "particle": "alpha",
        "energy": "5.3 MeV",
        "direction": "isotropic",
        "surface": {"volume": "cutbox", "face": "first.+z"},
    }
    data["run"] = {"events": 40, "seed": 11}
    data["output"] = {"steps": True}
    cfg = parse_config(data)
    out = tmp_path / "steps.h5"
    run(cfg, out, progress=False, echo=lambda m: None)
    res = read_results(out)
    table = lh5.read("stp/cutbox", str(out))
    evtid = np.asarray(table["evtid"].nda)
    edep = np.asarray(table["edep"].nda) / 1e3  # keV -> MeV
    per_event = np.bincount(evtid, weights=edep, minlength=res.n_events)
    np.testing.assert_allclose(per_event, res.edep["cutbox"], atol=1e-6, rtol=0)
    with h5py.File(out, "r") as f:
        g = f["stp/cutbox"]
        world = np.column_stack([g[c][()] * 1e3 for c in ("xloc", "yloc", "zloc")])
        dist = g["dist_to_surf"][()] * 1e3
    scene = build_scene(cfg)
    layer = scene.layer("cutbox", "first.+z")
    p = scene.target("cutbox").to_local(world)
    in_patch = layer.contains(world)
    assert in_patch.sum() > 0.2 * len(p)
    rough = RoughSurfaceDistance(layer)(world)
    others = np.minimum(
        box_faces(p, ["+x", "-x", "+y", "-y", "-z"]), np.hypot(p[:, 0], p[:, 1]) - BORE
    )
    np.testing.assert_allclose(dist, np.minimum(rough, others), rtol=0, atol=1e-12)
    assert dist[in_patch].max() > 1e-3  # micrometres inside a pyramid, not 0
    under = ~in_patch & (others > rough)
    assert under.sum() > 10
    assert np.all(rough[under] >= HALF - p[under, 2] + 1e-3 - 1e-12)  # the base: 1 um more
    w = weight(rough, 3e-3, 0.5)  # activeness lists first.+z only
    again = np.bincount(evtid, weights=edep * w, minlength=res.n_events)
    np.testing.assert_allclose(again, res.scores["active_edep"]["cutbox"], atol=1e-9, rtol=0)
    assert 0 < again.sum() < res.edep["cutbox"].sum()


@pytest.mark.deep
def test_replicas_on_an_uncut_boolean_face_track_as_placements(gdml, tmp_path):
    """native_layout replicas on the box's +x face, which the bore does not cut (every cell
    keeps its patch): geantinos through it have the same track length in the copper and its
    patches as with one placement per cell (1e-9 mm), and cross patches."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run

    got = {}
    n = 12
    rng = np.random.default_rng(3)
    local = np.column_stack([np.full(n, HALF + 0.1), rng.uniform(-9, 9, (n, 2))])
    direction = np.column_stack([-np.ones(n), rng.uniform(-0.2, 0.2, (n, 2))])
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    for layout in ("replicas", "placements"):
        rough = [{"face": "first.+x", "surface": "p", "native_layout": layout}]
        data = config(gdml, rough, output={"track_length": True})
        data["source"]["surface"]["face"] = "first.+x"
        cfg = parse_config(data)
        scene = build_scene(cfg)
        assert scene.layers[0].mask.all()
        target = scene.target("cutbox")
        primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
        folder = tmp_path / layout
        folder.mkdir()
        starts, dirs = target.to_world(local), direction @ target.rotation.T
        r = geantino_run(data, primaries, starts, dirs, folder)
        got[layout] = np.asarray(r.scores["track_length"]["cutbox"])
    np.testing.assert_allclose(got["replicas"], got["placements"], rtol=0, atol=1e-9)
    # the smooth box less the tube: from x = 10 to the bore or to the box's far side
    entry = local + (0.1 / -direction[:, 0])[:, None] * direction  # at x = 10
    smooth = np.array([_box_less_tube(entry[k], direction[k]) for k in range(n)])
    assert (got["replicas"] > smooth + 1e-4).sum() >= n // 2  # most rays cross a patch body
    assert (got["replicas"] < smooth + 0.03).all()  # in the 21 um layer, at most 0.2 rad off x


def _box_less_tube(o: np.ndarray, d: np.ndarray) -> float:
    """Path length of the ray o + s d (s > 0, o on or in the box) in the box less the bore."""
    # leave the box
    s_box = min((np.sign(d[a]) * HALF - o[a]) / d[a] for a in range(3) if d[a] != 0)
    a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
    c = o[0] ** 2 + o[1] ** 2 - BORE**2
    disc = b * b - 4 * a * c
    if disc <= 0:
        return float(s_box)
    s1, s2 = (-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)
    if s1 >= s_box or s2 <= 0:
        return float(s_box)
    return float(max(s1, 0.0) + max(s_box - s2, 0.0))


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            {"tiling": "portal"},
            (
                "a portal's subworlds must lie where no particle goes, which score4 knows only "
                "in the world it generates"
            ),
        ),
        # the subtracted tube's end (z = 20 mm) lies beyond the box (see test_into_subtracted)
        ({"into": True, "face": "second.+z"}, "lies nowhere on the solid's surface (area 0)"),
        (
            {"native_layout": "replicas", "face": "first.+z", "surface": "p"},
            # the 0.5 mm cells whose square reaches into the bore (r 5 mm): 352 of 40 x 40
            (
                "native_layout replicas fills every cell; 352 of the 1600 cells of face first.+z "
                "of 'cutbox'"
            ),
        ),
    ],
)
def test_portal_and_into_on_a_boolean_face_say_why_not(gdml, extra, message):
    data = config(gdml, [{"face": "first.+x", "surface": "fine", **extra}])
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(data))
    assert message in str(err.value)
    assert str(err.value).startswith("targets.0.rough.0: ")
    assert "\n" not in str(err.value)


def _box_minus_bore(o: np.ndarray, d: np.ndarray, top: float) -> float:
    """Path length of the ray o + s d (s > 0) in the box [-10, 10]^2 x [-10, top] less the
    cylinder r < 5 along z."""
    lo, hi = np.array([-HALF, -HALF, -HALF]), np.array([HALF, HALF, top])
    with np.errstate(divide="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    s0 = max(float(np.max(np.minimum(t1, t2))), 0.0)
    s1 = float(np.min(np.maximum(t1, t2)))
    if s1 <= s0:
        return 0.0
    a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
    disc = b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - BORE**2)
    if a == 0 or disc <= 0:
        return s1 - s0
    c0, c1 = (-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)
    return (s1 - s0) - max(0.0, min(s1, c1) - max(s0, c0))


@pytest.fixture(scope="module")
def into_top(gdml):
    """The box less the tube with a rough layer into the +z face around the bore."""
    rough = [{"face": "first.+z", "surface": "p", "into": True}]
    return config(gdml, rough, output={"track_length": True})


def test_into_a_boolean_face_cuts_the_box_below_it(into_top):
    """into: true on the box's +z face: the layer lies in the slab below where the face was (its
    top at z = 10), its kept cells on the cut face (a hair below: in the solid cut by the
    layer's thickness; a hair above: out of it), and points of the slab are no longer in the
    volume unless in a patch."""
    scene = build_scene(parse_config(into_top))
    layer = scene.layer("cutbox", "first.+z")
    target = scene.target("cutbox")
    t = layer.thickness
    base = target.to_local(layer.frame.centre[None])[0]
    assert base[2] == pytest.approx(HALF - t, abs=1e-12)
    on = layer.on_boolean
    centres = layer.cell_centres()[layer.mask]
    pts = layer.frame.to_world(np.column_stack([centres, np.zeros(len(centres))]))
    local = on.transform.inverse_apply(pts)
    assert (on.shape.inside(local - np.array([0, 0, 1e-6])) == 2).all()
    assert (on.shape.inside(local + np.array([0, 0, 1e-6])) == 0).all()
    r = np.hypot(local[:, 0], local[:, 1])
    assert r.min() > BORE
    assert 0.9 < layer.rough_share <= 1.0
    slab = target.to_world(np.array([[7.0, 7.0, HALF - t / 2], [7.0, 7.0, HALF - t - 1e-3]]))
    inside = scene.inside_target("cutbox", slab)
    assert inside[1]
    assert inside[0] == layer.contains(slab[:1])[0]


def test_geantino_paths_through_a_boolean_face_with_into(into_top, tmp_path):
    """Geantinos from above the cut +z face, aimed into the solid: Geant4's track length in the
    target (rebuilt with the box made thinner) equals the analytic path in the box cut to
    z = 10 - t less the cylinder plus the path in the patch bodies near the ray, 1e-9 mm."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run
    from helpers.ray_trace import flat_patches_path

    cfg = parse_config(into_top)
    scene = build_scene(cfg)
    layer = scene.layer("cutbox", "first.+z")
    target = scene.target("cutbox")
    t = layer.thickness
    rng = np.random.default_rng(7)
    centres = layer.cell_centres()[layer.mask]
    starts, directions = [], []
    for _ in range(12):
        c = centres[rng.integers(len(centres))] + rng.uniform(-0.2, 0.2, 2)
        start = layer.frame.to_world(np.array([*c, t + 0.01]))
        aim = target.to_world(np.array([rng.uniform(-9, 9), rng.uniform(-9, 9), -9.0]))
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    n = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(into_top, primaries, np.array(starts), np.array(directions), tmp_path)
    crossed = 0
    for k in range(n):
        o, d = starts[k], directions[k]
        expected = _box_minus_bore(target.to_local(o[None])[0], d @ target.rotation, HALF - t)
        in_patches = flat_patches_path(layer, o, d)
        crossed += in_patches > 0
        got = r.scores["track_length"]["cutbox"][k]
        assert got == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2


@pytest.mark.deep
@pytest.mark.parametrize("face", ["first.+z", "second.outer"])
def test_a_boolean_face_with_into_exports_with_the_same_paths(gdml, face, tmp_path, monkeypatch):
    """The box less the tube cut for an into layer on its +z face (the boolean rebuilt around
    the thinner box) or on the bore (around the wider tube), written by `score4 geometry
    export`: Geant4 reads the file back, and the file pyg4ometry reads and writes again, with
    the same geantino paths (volumes and points, 1e-9 mm)."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    surface = "fine" if face == "second.outer" else "p"
    data = config(gdml, [{"face": face, "surface": surface, "into": True}])
    data["source"]["surface"]["face"] = face
    cfg = tmp_path / "into.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "into.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(11)
    rays = []
    for _ in range(8):
        if face == "first.+z":  # from 0.5 mm above the +z face (some over the bore), in
            start = np.array([*rng.uniform(-9.5, 9.5, 2), HALF + 0.5])
            d = np.array([*rng.uniform(-9.5, 9.5, 2), -9.5]) - start
        else:  # from 1 mm off the axis, out through the bore's wall
            phi = rng.uniform(0, 2 * np.pi)
            start = np.array([np.cos(phi), np.sin(phi), rng.uniform(-7, 7)])
            d = np.array([np.cos(phi + 0.3), np.sin(phi + 0.3), rng.uniform(-0.3, 0.3)])
        rays.append((start.tolist(), (d / np.linalg.norm(d)).tolist()))
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("rough" in (v or "") for v, _ in path) for path in ours) >= 4


@pytest.mark.deep
def test_into_a_bore_widens_it_and_keeps_the_paths(gdml, tmp_path):
    """into: true on the bore's wall (the subtracted tube's outer wall): the subtracted tube
    grows by the layer's cut, the layer lies in the shell between the old bore and the new one;
    geantinos from near the axis, out through the wall: Geant4's track length in the target
    equals the analytic path in the box less the wider cylinder plus the path in the bent patch
    bodies near the crossing, to 1e-9 mm."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run
    from helpers.ray_trace import mesh_path, wall_patches_near

    rough = [{"face": "second.outer", "surface": "fine", "into": True}]
    data = config(gdml, rough, output={"track_length": True})
    data["source"]["surface"]["face"] = "second.outer"
    cfg = parse_config(data)
    scene = build_scene(cfg)
    layer = scene.layer("cutbox", "second.outer")
    target = scene.target("cutbox")
    wide = BORE + layer.cut_shape[0].rmin - layer.target.shape.rmin  # the bore after the cut
    assert wide - BORE == pytest.approx(layer.thickness, rel=0.05)
    shell = target.to_local(layer.shell_points())
    r = np.hypot(shell[:, 0], shell[:, 1])
    assert r.min() >= BORE - 1e-9
    assert r.max() <= wide + 1e-9
    rng = np.random.default_rng(13)
    n = 10
    phi, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-7, 7, n)
    local = np.column_stack([np.cos(phi), np.sin(phi), z])  # at radius 1 mm
    out = np.column_stack([np.cos(phi + 0.3), np.sin(phi + 0.3), rng.uniform(-0.3, 0.3, n)])
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    starts, directions = target.to_world(local), out @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    got = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(got.scores["track_length"]["cutbox"])
    crossed = 0
    for k in range(n):
        o, d = local[k], out[k]
        a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
        s_wide = (-b + np.sqrt(b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - wide**2))) / (2 * a)
        expected = _box_minus_cylinder_from_inside(o, d, s_wide)
        hit = o + s_wide * d
        tri = wall_patches_near(layer, target, hit, 2 / 5)
        in_patches = mesh_path(o, d, tri, edge=1e-12, merge=1e-10)
        crossed += in_patches > 0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2


def _box_minus_cylinder_from_inside(o: np.ndarray, d: np.ndarray, s_wall: float) -> float:
    """Path of a ray from inside the bore (o + s d, leaving the cylinder at s_wall) in the box:
    from the wall to the box's side."""
    with np.errstate(divide="ignore"):
        s_box = float(np.min(np.where(d != 0, (np.sign(d) * HALF - o) / d, np.inf)))
    return max(s_box - s_wall, 0.0)


@pytest.mark.deep
def test_into_the_top_of_a_union_part(gdml, tmp_path):
    """into: true on the post's top (the end face of the union's second tube) and the disk's
    bottom: the tubes made shorter there, the union rebuilt (the post's shift carried into its
    placement); vertical geantinos through both layers: Geant4's track length in the target is
    20 mm less both cuts plus the paths in the patch bodies near each ray, to 1e-9 mm."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run
    from helpers.ray_trace import mesh_path

    rough = [
        {"face": "second.+z", "surface": "p", "into": True},
        {"face": "first.-z", "surface": "p", "into": True},
    ]
    data = config(gdml, rough, output={"track_length": True})
    data["targets"][0]["volume"] = "stack"
    data["source"]["surface"] = {"volume": "stack", "face": "second.+z"}
    cfg = parse_config(data)
    scene = build_scene(cfg)
    target = scene.target("stack")
    layers = [scene.layer("stack", f) for f in ("second.+z", "first.-z")]
    rng = np.random.default_rng(17)
    n = 8
    r, phi = 6.5 * np.sqrt(rng.uniform(0, 1, n)), rng.uniform(0, 2 * np.pi, n)
    local = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.full(n, 16.0)])
    down = np.tile([0.0, 0.0, -1.0], (n, 1))
    starts, directions = target.to_world(local), down @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    got = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(got.scores["track_length"]["stack"])
    crossed = 0
    for k in range(n):
        o, d = starts[k], directions[k]
        expected = 20.0 - sum(layer.thickness for layer in layers)
        for layer in layers:
            body = layer.variants[0].body(layer.base_thickness)
            cc = layer.cell_centres()
            q = layer.frame.to_local(o[None])[0]
            px, py = layer.patch_size
            near = (np.abs(cc[..., 0] - q[0]) < px) & (np.abs(cc[..., 1] - q[1]) < py)
            path = 0.0
            for j, i in zip(*np.nonzero(near & layer.mask), strict=True):
                v = body.vertices + np.array([*cc[j, i], layer.base_thickness])
                path += mesh_path(
                    o, d, layer.frame.to_world(v)[body.faces], edge=1e-12, merge=1e-10
                )
            crossed += path > 0
            expected += path
        assert got[k] == pytest.approx(expected, abs=1e-9, rel=0), k
    assert crossed >= n
