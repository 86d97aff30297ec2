"""Rough layers on boolean faces refused before session 10 (score4.world.boolean_layers): a
face of a union partly covered by its other part (a box with a post on its +z face, a disk
with a post, a box a rod runs through), whose layer keeps the cells clear of that part and
whose envelope is the prism of those cells, and the bore a subtracted G4Cons leaves."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.geometry.check import curved_cells_tile
from score4.inputs.config import parse_config
from score4.shapes.base import INSIDE
from score4.source.build import layer_sampler, make_source, source_geometry
from score4.world import boolean_layers
from score4.world.clearance import check_clearance
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.boolean_worlds import (
    CONEBORE_POSITION,
    CROSS_POSITION,
    HEX_CUT,
    HEXCUT_POSITION,
    ORB_CUT,
    ORBCUT_POSITION,
    POST_AT,
    POSTBOX_POSITION,
    STACK_POSITION,
    write_cone_cross,
    write_more_world,
)
from helpers.export_paths import assert_same_paths, base_name, three_paths
from helpers.g4_geometry_check import assert_no_overlaps
from helpers.geantinos import geantino_config, geantino_run, rough_targets
from helpers.ray_trace import (
    flat_patches_path,
    mesh_path,
    patches_path,
    polycone_path,
    wall_patches_near,
)

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
#: 0.4 mm patches: fine enough to bend onto the cone's bore (r 5 to 7 mm in the box)
FINE = {**PYRAMIDS, "width": "80 um"}


def config(gdml: Path, rough: dict[str, list], surface=PYRAMIDS, **extra) -> dict:
    volume, faces = next(iter(rough.items()))
    return geantino_config(gdml, {"p": surface}, rough_targets(rough), (volume, faces[0]), **extra)


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    return write_more_world(tmp_path_factory.mktemp("boolean") / "more.gdml")


def _nearest(layer, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every cell: the least and the largest distance (in the face's plane) from a point of
    the cell's rectangle to ``centre`` (frame-local x, y)."""
    px, py = layer.patch_size
    d = np.abs(layer.cell_centres() - centre)
    near = np.hypot(np.maximum(d[..., 0] - px / 2, 0), np.maximum(d[..., 1] - py / 2, 0))
    return near, np.hypot(d[..., 0] + px / 2, d[..., 1] + py / 2)


@pytest.mark.parametrize(
    ("volume", "axis", "radius"),
    [
        pytest.param("postbox", POST_AT[:2], 3.0, id="box-with-a-post"),
        pytest.param("cross", (0.0, 0.0), 5.0, id="box-a-rod-runs-through"),
        pytest.param("stack", (0.0, 0.0), 7.0, id="disk-with-a-post"),
    ],
)
def test_a_partly_covered_union_face_keeps_the_cells_clear_of_the_other_part(
    gdml, volume, axis, radius
):
    """The +z face of a union whose other part (a tube) stands on it or runs through it: the
    kept cells are those whose rectangle stays clear of the tube or touches it (an exact count
    from the cells' nearest points to its axis), less at most those within 0.01 mm of it (left
    unproven); the
    envelope is the kept cells' prism, wholly outside the solid; the rough share is the kept
    cells' area over the boolean face's (estimated) area."""
    scene = build_scene(parse_config(config(gdml, {volume: ["first.+z"]})))
    (layer,) = scene.layers
    assert layer.cells_envelope
    on = layer.on_boolean
    centre = layer.frame.to_local(on.transform.apply(np.array([[*axis, 10.0]])))[0, :2]
    near, far = _nearest(layer, centre)
    face = layer.cell_variants >= 0  # kept
    inner = near >= radius  # a cell may touch the tube (its bounding box proves it then)
    if volume == "stack":  # a disk: the cells wholly on it
        inner &= far <= 10.0
    else:  # a box: every cell of the 20 mm face
        assert layer.cell_variants.shape == (40, 40)
    assert not (face & ~inner).any()
    rim = inner & (near < radius + 0.01)
    assert not (inner & ~face & ~rim).any()
    assert face.sum() > 0.9 * inner.sum()
    px, py = layer.patch_size
    area = on.shape.face_areas[on.face]
    assert layer.rough_share == pytest.approx(face.sum() * px * py / area, rel=1e-12)
    # the envelope: the prism of the kept cells, its points outside the solid
    prism = layer.envelope_prism()
    assert prism is not None
    assert len(prism.faces) > 4 * face.sum()
    pts = layer.envelope_points()
    local = on.transform.inverse_apply(pts)
    assert not (on.shape.inside(local) == INSIDE).any()
    h = layer.frame.to_local(pts)[:, 2]
    assert h.min() == pytest.approx(0.0, abs=1e-12)
    assert h.max() == pytest.approx(layer.thickness, rel=1e-12)
    # a point just above the face over the tube is not in the envelope, one over a cell is
    over = layer.frame.to_world(np.array([[*centre, layer.thickness / 2]]))
    assert not layer.in_envelope(over).any()
    j, i = np.argwhere(face)[0]
    cell = layer.frame.to_world(np.array([[*layer.cell_centres()[j, i], layer.thickness / 2]]))
    assert layer.in_envelope(cell).all()


def test_a_wall_rising_from_a_partly_covered_face_leaves_its_foot_flat(gdml):
    """The disk's +z face and the post's wall rough together: the face's cells also keep clear
    of the wall's layer (its thickness beyond the post), proven, not sampled; the wall keeps
    the row of cells along its seam with the disk."""
    scene = build_scene(parse_config(config(gdml, {"stack": ["first.+z", "second.outer"]})))
    top, wall = scene.layers
    assert top.cells_envelope
    assert isinstance(wall, CurvedRoughLayer)
    # the wall keeps every cell, the row along its seam with the disk included
    assert wall.mask.sum() == wall.ring_layout.count.sum()
    near, _ = _nearest(top, np.zeros(2))
    kept = top.cell_variants >= 0
    assert near[kept].min() > 7.0 + wall.thickness
    alone = build_scene(parse_config(config(gdml, {"stack": ["first.+z"]}))).layers[0]
    lost = (alone.cell_variants >= 0) & ~kept
    assert (near[lost] <= 7.0 + wall.thickness + 0.01).all()


def _box_path(o: np.ndarray, d: np.ndarray, lo, hi) -> tuple[float, float]:
    t0, t1 = 0.0, np.inf
    for k in range(3):
        if abs(d[k]) < 1e-15:
            if not lo[k] < o[k] < hi[k]:
                return 0.0, 0.0
            continue
        a, b = (lo[k] - o[k]) / d[k], (hi[k] - o[k]) / d[k]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    return (t0, t1) if t1 > t0 else (0.0, 0.0)


def _tube_path(o: np.ndarray, d: np.ndarray, centre, r: float, z0: float, z1: float) -> float:
    """Path of a ray (from t = 0) in the cylinder of radius r about the z line through
    ``centre`` (x, y), z0 < z < z1."""
    ox, oy = o[0] - centre[0], o[1] - centre[1]
    a = d[0] ** 2 + d[1] ** 2
    b = 2 * (ox * d[0] + oy * d[1])
    c = ox**2 + oy**2 - r * r
    if a < 1e-15:
        t0, t1 = (0.0, np.inf) if c < 0 else (0.0, 0.0)
    else:
        disc = b * b - 4 * a * c
        if disc <= 0:
            return 0.0
        t0, t1 = (-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)
    if abs(d[2]) > 1e-15:
        a_, b_ = (z0 - o[2]) / d[2], (z1 - o[2]) / d[2]
        t0, t1 = max(t0, min(a_, b_)), min(t1, max(a_, b_))
    elif not z0 < o[2] < z1:
        return 0.0
    t0 = max(t0, 0.0)
    return max(t1 - t0, 0.0)


def test_geantino_paths_through_a_partly_covered_union_face(gdml, tmp_path):
    """Geantinos from just above kept cells of the box's +z face (half of them beside the
    post), aimed at points of the box or the post: Geant4's track length in the target equals
    the analytic path in the box plus the post (they only touch) plus the path in the patch
    bodies near the ray, to 1e-9 mm."""
    data = config(gdml, {"postbox": ["first.+z"]}, output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    (layer,) = scene.layers
    target = scene.target("postbox")
    rng = np.random.default_rng(7)
    kept = layer.cell_variants >= 0
    axis = layer.frame.to_local(target.to_world(np.array([[*POST_AT[:2], 10.0]])))[0, :2]
    near, _ = _nearest(layer, axis)
    close = np.argwhere(kept & (near < 3.6))  # within 0.6 mm of the post
    anywhere = np.argwhere(kept)
    starts, directions = [], []
    for k in range(14):
        j, i = (close if k % 2 else anywhere)[rng.integers(len(close if k % 2 else anywhere))]
        c = layer.cell_centres()[j, i] + rng.uniform(-0.2, 0.2, 2)
        start = layer.frame.to_world(np.array([*c, 0.03]))
        if k % 3 == 0:  # into the post
            aim = np.array([POST_AT[0], POST_AT[1], rng.uniform(11, 19)])
            aim[:2] += rng.uniform(-2, 2, 2)
            aim = target.to_world(aim[None])[0]
        else:
            aim = target.to_world(rng.uniform(-9.5, 9.5, (1, 3)))[0]
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    n = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    got = np.asarray(r.scores["track_length"]["postbox"])
    into_post = 0
    for k in range(n):
        o, d = starts[k], directions[k]
        lo_, dl = target.to_local(o[None])[0], d @ target.rotation
        t0, t1 = _box_path(lo_, dl, (-10, -10, -10), (10, 10, 10))
        post = _tube_path(lo_, dl, POST_AT[:2], 3.0, 10.0, 20.0)
        into_post += post > 0
        expected = (t1 - t0) + post + flat_patches_path(layer, o, d)
        assert got[k] == pytest.approx(expected, abs=1e-9, rel=0), k
    assert into_post >= 3


def test_a_bore_in_a_cone_takes_a_rough_layer_inside_it(gdml):
    """The wall a subtracted G4Cons leaves (r 6 + 0.1 z mm in the box): its layer lies in the
    bore (its shell between the wall and the axis, ending where the box does); the kept cells
    lie on the boolean's surface (a hair towards the axis outside the solid, a hair away
    inside); every cell clear of the box's end faces is kept."""
    scene = build_scene(parse_config(config(gdml, {"conebore": ["second.outer"]}, FINE)))
    (layer,) = scene.layers
    assert isinstance(layer, CurvedRoughLayer)
    on = layer.on_boolean
    lay = layer.ring_layout
    pts = []
    for j, _i, _v, phi in layer.cells():
        u = phi + np.linspace(-0.49, 0.49, 3) * lay.step[j]
        v = lay.v[j] + np.linspace(-0.49, 0.49, 3) * layer.patch_size[1]
        uu, vv = np.meshgrid(u, v)
        pts.append(layer.target.to_world(lay.face.point(uu.ravel(), vv.ravel())))
    pts = on.transform.inverse_apply(np.concatenate(pts))
    radial = np.column_stack([pts[:, 0], pts[:, 1], np.zeros(len(pts))])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    rho = np.hypot(pts[:, 0], pts[:, 1])
    assert np.abs(rho - (6 + 0.1 * pts[:, 2])).max() < 1e-9
    assert (on.shape.inside(pts + 1e-6 * radial) == INSIDE).all()
    assert (on.shape.inside(pts - 1e-6 * radial) != INSIDE).all()
    shell = on.transform.inverse_apply(layer.shell_points())
    r = np.hypot(shell[:, 0], shell[:, 1])
    assert (r <= 6 + 0.1 * shell[:, 2] + 1e-9).all()
    assert np.abs(shell[:, 2]).max() <= 10 + layer.thickness
    inner = np.abs(lay.v) < lay.v.max() - layer.patch_size[1] / 2  # rows clear of the ends
    assert (layer.mask[inner] == (layer.cell_variants[inner] >= 0)).all()
    assert 0.95 < layer.rough_share < 1
    share = layer.mask.sum() * np.prod(layer.patch_size) / on.shape.face_areas[on.face]
    assert layer.rough_share == pytest.approx(share, rel=1e-12)


def test_a_cone_bore_and_the_face_around_it_are_clear_of_each_other(gdml):
    """The bore's layer with the layer of the box's +z face around the bore's wide end (r 7 mm):
    accepted. The bore's envelope is the G4Cons Geant4 places, between the z planes of the
    bore's ends: its points stop at the +z plane (the shell moved along the slanted normal
    reached 2 um above it, into the face's layer, and the pair was refused with a free gap of
    0 um). The face's layer let down by 0.1 um into the box does meet the bore's envelope at
    its top rim: refused, naming both layers."""
    scene = build_scene(
        parse_config(config(gdml, {"conebore": ["second.outer", "first.+z"]}, FINE))
    )
    bore, face = scene.layers
    assert bore.on_boolean is not None
    shell = bore.on_boolean.transform.inverse_apply(bore.shell_points())
    assert shell[:, 2].max() <= 10 + 1e-12
    rim = np.hypot(shell[:, 0], shell[:, 1])[shell[:, 2] > 10 - 1e-9]
    assert rim.max() == pytest.approx(7, abs=1e-9)  # the envelope's top reaches the face's plane
    assert rim.min() < 7 - 0.9 * bore.thickness
    frame = face.frame
    lowered = dataclasses.replace(frame, centre=frame.centre - 1e-4 * frame.normal)
    scene.layers[1] = dataclasses.replace(face, frame=lowered)
    with pytest.raises(ConfigError, match="runs into the rough layer conebore_roughfirst_pz"):
        check_clearance(scene)


def _box_less_cone_path(o: np.ndarray, d: np.ndarray) -> tuple[float, np.ndarray]:
    """Path of a ray from inside the bore (box frame) in the box |x|,|y|,|z| < 10 less the
    cone r < 6 + 0.1 z, and where it leaves the bore."""
    a = d[0] ** 2 + d[1] ** 2 - (0.1 * d[2]) ** 2
    r0 = 6 + 0.1 * o[2]
    b = 2 * (o[0] * d[0] + o[1] * d[1]) - 2 * 0.1 * d[2] * r0
    c = o[0] ** 2 + o[1] ** 2 - r0 * r0
    t = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    _, t1 = _box_path(o, d, (-10, -10, -10), (10, 10, 10))
    return t1 - t, o + t * d


@pytest.mark.deep
def test_geantino_paths_through_a_rough_cone_bore(gdml, tmp_path):
    """Geantinos from near the cone bore's axis, out through the rough wall into the box:
    Geant4's track length in the target equals the analytic path in the box less the cone plus
    the path in the bent patch bodies near the crossing, to 1e-9 mm (deep: ~9 s, the bore's 50
    rings of bent patches)."""
    data = config(gdml, {"conebore": ["second.outer"]}, FINE, output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    (layer,) = scene.layers
    target = scene.target("conebore")
    rng = np.random.default_rng(13)
    n = 10
    phi, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-7, 7, n)
    local = np.column_stack([np.cos(phi), np.sin(phi), z])
    out = np.column_stack([np.cos(phi + 0.3), np.sin(phi + 0.3), rng.uniform(-0.3, 0.3, n)])
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    starts, directions = target.to_world(local), out @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(r.scores["track_length"]["conebore"])
    crossed = 0
    for k in range(n):
        o, d = local[k], out[k]
        expected, hit = _box_less_cone_path(o, d)
        assert abs(hit[2]) < 9
        tri = wall_patches_near(layer, target, hit, 2 / 6)
        in_patches = mesh_path(o, d, tri, edge=1e-12, merge=1e-10)
        crossed += in_patches > 0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2


@pytest.mark.deep
def test_new_boolean_faces_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The box's +z face around its post, the disk's +z face around its post with the post's
    wall, the cone's bore, the orb's sphere face and the prism's six sides, written by
    `score4 geometry export`: Geant4 reads the file back
    with the same geantino paths (1e-9 mm), and so it reads the file pyg4ometry reads and writes
    again (deep: ~40 s, the bore's 50 rings of bent patches)."""
    data = config(gdml, {"postbox": ["first.+z"], "stack": ["first.+z", "second.outer"]})
    bore = {"volume": "conebore", "rough": [{"face": "second.outer", "surface": "q"}]}
    orb = {"volume": "orbcut", "rough": [{"face": "first.outer", "surface": "s"}]}
    sides = {"volume": "hexcut", "rough": [{"face": "first.outer", "surface": "p"}]}
    data["targets"] += [bore, orb, sides]
    data["surfaces"] |= {"q": FINE, "s": SMALL}
    cfg = tmp_path / "boolean.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "boolean_rough.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(11)
    rays = []
    box = np.array(POSTBOX_POSITION)
    for _ in range(5):  # from 0.5 mm above the box's +z face, near the post, into the box
        start = box + np.array([*(np.array(POST_AT[:2]) + rng.uniform(-4.5, 4.5, 2)), 10.5])
        aim = box + rng.uniform(-9.5, 9.5, 3)
        rays.append((start, aim - start))
    stack = np.array(STACK_POSITION)
    for k in range(6):  # from 0.5 mm above the disk's ring, down and towards the post's foot
        phi = rng.uniform(0, 2 * np.pi)
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        r, slope = (9.0, 0.3) if k % 2 else (7.6, 0.8)
        rays.append((stack + r * radial + [0, 0, 5.5], -slope * radial + [0, 0, -1.0]))
    cone = np.array(CONEBORE_POSITION)
    for _ in range(5):  # from the cone's axis out through its wall
        phi = rng.uniform(0, 2 * np.pi)
        way = np.array([np.cos(phi), np.sin(phi), 0.1])
        rays.append((cone + np.array([0, 0, rng.uniform(-7, 7)]), way))
    orb_at = np.array(ORBCUT_POSITION)
    for _ in range(4):  # from outside the orb (r 3 mm) into it, on the side the cut spares
        phi = rng.uniform(0.6 * np.pi, 1.4 * np.pi)
        radial = np.array([np.cos(phi), np.sin(phi), rng.uniform(-0.3, 0.3)])
        rays.append((orb_at + 3.3 * radial, -radial))
    hex_at = np.array(HEXCUT_POSITION)
    for k in range(4):  # from outside the prism's sides (8 mm from its axis) into it
        a = math.radians(90 + 60 * k)
        n = np.array([math.cos(a), math.sin(a), 0.0])
        side = np.array([-n[1], n[0], 0.0]) * rng.uniform(-3, 3)  # off the cells' edges
        rays.append((hex_at + 8.5 * n + side + [0, 0, rng.uniform(-8, 8)], -n + [0, 0, 0.1]))
    rays = [(o.tolist(), (d / np.linalg.norm(d)).tolist()) for o, d in rays]
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    crossed = {base_name(v) for path in ours for v, _ in path}
    for layer in (
        "postbox_roughfirst_pz",
        "stack_roughfirst_pz",
        "conebore_roughsecond_outer",
        "orbcut_roughfirst_outer",
        "hexcut_roughfirst_seg_1",
    ):
        assert any(v and v.startswith(layer) for v in crossed), layer  # each layer's patches
    assert_same_paths(ours, back, relay)  # the prism's sides: each plane's own names


#: the rod's wall where it runs through the box, and the box's face around it
CROSS_ROUGH = {"cross": ["second.outer", "first.+z"]}
#: the cone's wall where it runs through the box, and the box's faces around it
#: (tests/test_cone_pieces.py)
CONE_CROSS_ROUGH = {"conecross": ["second.outer", "first.+z"]}


def test_a_rods_wall_through_a_box_takes_a_layer_on_both_sides(gdml):
    """The wall of a rod (r 5 mm, 40 mm) running through a box (20 mm, a union): the rings
    inside the box hold no cell, so the envelope is two pieces (G4Tubs), each from an end of
    the rod to the box's face (touching it, no more), with every kept cell in one; no point of
    the envelope lies inside the solid. (Before, the whole shell ran through the box and the
    layer was refused.)"""
    scene = build_scene(parse_config(config(gdml, {"cross": ["second.outer"]}, FINE)))
    wall = scene.layer("cross", "second.outer")
    assert isinstance(wall, CurvedRoughLayer)
    assert wall.pieces is not None
    a, b = sorted(wall.pieces, key=lambda p: p.v0)
    (_, da, va0, va1, _), (_, db, vb0, vb1, _) = a, b
    assert da == db == pytest.approx(2 * np.pi, abs=1e-12)
    assert (va0, vb1) == (-20.0, 20.0)
    assert va1 == pytest.approx(-10.0, abs=1e-9)
    assert vb0 == pytest.approx(10.0, abs=1e-9)
    lay, py = wall.ring_layout, wall.patch_size[1]
    outside = np.abs(lay.v) >= 10 + py / 2 - 1e-9  # rings wholly beyond the box's faces
    assert not wall.mask[~outside].any()
    assert wall.mask[outside].all()
    on = wall.on_boolean
    codes = on.shape.inside(on.transform.inverse_apply(wall.shell_points(n_v=41)))
    assert not (codes == INSIDE).any()
    assert not curved_cells_tile(wall)[1]  # geometry check's exact tiling: cells in pieces
    wall.pieces = [a._replace(v1=va1 - py), b]  # a ring left out of its piece
    assert any("outside the pieces" in p for p in curved_cells_tile(wall)[1])


def test_a_curved_layer_whose_envelope_meets_the_solid_is_one_line(gdml, monkeypatch):
    """Where the envelope cannot be cut down to the kept cells (here: forced to the whole
    shell), a curved layer running into the solid is refused in one line."""
    monkeypatch.setattr(boolean_layers, "envelope_pieces", lambda layer: None)
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, {"cross": ["second.outer"]}, FINE)))
    assert "runs into the solid itself" in str(err.value)
    assert "face second.outer of 'cross'" in str(err.value)
    assert "\n" not in str(err.value)


#: a wall through a box (a union): the rod's (r 5 mm) and the cone's (r 4 to 6 mm over 40 mm,
#: tests/test_cone_pieces.py), each with the box's face around it. Per wall: the target, its rough
#: faces, the world's GDML writer, the rays' seed, the least distance from the axis of the rays
#: onto the box's face, and the wall's radius at z.
WALLS_THROUGH_A_BOX = {
    "rod": ("cross", CROSS_ROUGH, write_more_world, 5, 5.5, lambda z: 5.0),
    "cone": ("conecross", CONE_CROSS_ROUGH, write_cone_cross, 7, 6.0, lambda z: 5.0 + z / 20),
}


@pytest.mark.deep
@pytest.mark.parametrize("wall_kind", list(WALLS_THROUGH_A_BOX))
def test_a_wall_through_a_box_in_geant4(wall_kind, tmp_path):
    """The rod's or the cone's wall (two envelope pieces) and the box's +z face around it:
    Geant4's overlap check finds no overlap, and geantinos through the wall's layer (both pieces)
    and the face's layer into the solid travel in it the path in the box and the rod or cone
    (their signed distance, bisected) plus the path in the patch bodies near the ray, to 1e-9 mm."""
    volume, rough, write_world, seed, r_face, wall_radius = WALLS_THROUGH_A_BOX[wall_kind]
    gdml = write_world(tmp_path / f"{volume}.gdml")
    data = config(gdml, rough, FINE, output={"track_length": True})
    (tmp_path / f"{volume}.yaml").write_text(yaml.safe_dump(data))
    assert_no_overlaps(tmp_path / f"{volume}.yaml")
    cfg = parse_config(data)
    scene = build_scene(cfg)
    target = scene.target(volume)
    face, wall = scene.layer(volume, "first.+z"), scene.layer(volume, "second.outer")
    rng = np.random.default_rng(seed)
    starts, directions = [], []
    for k in range(12):
        if k < 4:  # from above the box's face, beside the rod or cone
            phi, r = rng.uniform(0, 2 * np.pi), rng.uniform(r_face, 9)
            o = np.array([r * np.cos(phi), r * np.sin(phi), 10.05])
        else:  # from just outside the wall, above and below the box
            phi, z = rng.uniform(0, 2 * np.pi), rng.uniform(10.5, 19) * (1 if k % 2 else -1)
            r = wall_radius(z) + 0.06
            o = np.array([r * np.cos(phi), r * np.sin(phi), z])
        aim = target.shape.sample_volume(rng, 1)[0]
        starts.append(target.to_world(o[None])[0])
        directions.append(target.rotation @ ((aim - o) / np.linalg.norm(aim - o)))
    n = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    got = np.asarray(r.scores["track_length"][volume])
    crossed, pieces = 0, set()
    for k in range(n):
        o, d = starts[k], directions[k]
        expected = polycone_path(target.to_local(o[None])[0], target.rotation.T @ d,
                                 target.shape, length=60.0)  # fmt: skip
        in_wall = patches_path(o, d, wall, 60.0)
        in_patches = patches_path(o, d, face, 60.0) + in_wall
        crossed += in_patches > 0
        if k >= 4 and in_wall > 0:
            pieces.add(k % 2)  # above the box (odd) or below it (even)
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2  # most rays cross a patch body
    assert pieces == {0, 1}  # through both pieces of the wall's envelope


@pytest.mark.deep
def test_a_rods_wall_in_two_pieces_exports_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The rod's wall through the box (two envelope pieces) and the box's face around it,
    written by `score4 geometry export`: Geant4 reads the file back with the same geantino
    paths (1e-9 mm), and so it reads the file pyg4ometry reads and writes again; the rays
    cross both pieces."""
    cfg = tmp_path / "cross.yaml"
    cfg.write_text(yaml.safe_dump(config(gdml, CROSS_ROUGH, FINE)))
    out = tmp_path / "cross_rough.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(3)
    centre = np.array(CROSS_POSITION)
    rays = []
    for k in range(8):  # from outside the rod's wall, above and below the box, into the solid
        phi, z = rng.uniform(0, 2 * np.pi), rng.uniform(11, 19) * (1 if k % 2 else -1)
        start = centre + np.array([5.1 * np.cos(phi), 5.1 * np.sin(phi), z])
        aim = centre + np.array([*rng.uniform(-3, 3, 2), z - np.sign(z) * rng.uniform(0, 8)])
        rays.append((start, aim - start))
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    walls = [any(v and v.startswith("cross_roughsecond_outer") for v, _ in p) for p in ours]
    assert any(walls[0::2])  # below the box: the first piece
    assert any(walls[1::2])  # above it: the second
    assert_same_paths(ours, back, relay)


@pytest.mark.deep
def test_geant4_finds_no_overlap_in_the_new_boolean_layers(gdml, tmp_path, capsys):
    """Geant4's own overlap check over the layers on the box's face around its post and the
    disk's face around its post: their prism envelopes and every cell in them. (The post's
    wall is left out: Geant4 finds the cells of its first ring sticking out of the ring's
    G4Tubs, as on main before these layers; the check skips a bore's bent patches past 500.)"""
    data = config(gdml, {"postbox": ["first.+z"], "stack": ["first.+z"]})
    (tmp_path / "check.yaml").write_text(yaml.safe_dump(data))
    assert main(["geometry", "check", str(tmp_path / "check.yaml")]) == 0
    assert "no overlaps" in capsys.readouterr().out


#: 0.1 mm patches of 10 x 10 pyramids 10 um high, for the orb (r 3 mm)
SMALL = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}


def _orb_less_box_path(o: np.ndarray, d: np.ndarray, layer) -> float:
    """Path of a ray (orb frame) in the orb r < 3 less the half-space x > 1.5 (the box), plus
    the path in the bent patch bodies of the kept cells near where it crosses the sphere."""
    b, c = o @ d, o @ o - 9.0
    disc = b * b - c
    if disc <= 0:
        return 0.0
    t1, t2 = -b - math.sqrt(disc), -b + math.sqrt(disc)
    if abs(d[0]) > 1e-15:  # x < 1.5
        tc = (ORB_CUT - o[0]) / d[0]
        t1, t2 = (t1, min(t2, tc)) if d[0] > 0 else (max(t1, tc), t2)
    total = max(t2 - t1, 0.0)
    lay = layer.ring_layout
    px, py = layer.patch_size
    for t in (-b - math.sqrt(disc), -b + math.sqrt(disc)):
        p = o + t * d
        _, v0, _ = lay.face.locate(p[None])
        phi0 = math.atan2(p[1], p[0])
        for j in np.flatnonzero((np.abs(lay.v - v0[0]) < 3 * py) & (lay.count > 0)):
            for i, phi in enumerate(lay.cell_phi(int(j))):
                dphi = (phi - phi0 + math.pi) % (2 * math.pi) - math.pi
                if abs(dphi) * lay.radius[j] > 3 * px or layer.cell_variants[j, i] < 0:
                    continue
                body = layer.bent(int(layer.cell_variants[j, i]), int(j))
                cs, sn = math.cos(phi), math.sin(phi)
                v = body.vertices @ np.array([[cs, sn, 0], [-sn, cs, 0], [0, 0, 1]])
                tri = (v + np.array([0.0, 0.0, lay.ring_z(int(j))]))[body.faces]
                total += mesh_path(o, d, tri)
    return total


def test_the_sphere_face_of_an_orb_less_a_box_takes_a_rough_layer(gdml, tmp_path):
    """An orb (r 3 mm) less a box beyond x = 1.5 mm, its sphere face rough: the kept cells lie
    on the boolean's surface (x < 1.5 over the whole cell, every cell of a ring clear of the
    cut kept); the rough share is the kept cells' exact band areas over the face's estimated
    area; geantinos from just outside kept cells into the orb: Geant4's track length equals
    the analytic path in the orb less the half-space plus the path in the bent patch bodies
    of the kept cells, to 1e-9 mm."""
    data = config(gdml, {"orbcut": ["first.outer"]}, SMALL, output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    (layer,) = scene.layers
    assert isinstance(layer, CurvedRoughLayer)
    lay = layer.ring_layout
    target = scene.target("orbcut")
    px, py = layer.patch_size
    kept = layer.cell_variants >= 0
    corners = []
    for j, _i, _v, phi in layer.cells():
        u = phi + np.array([-0.5, 0.5, 0.5, -0.5, 0.0]) * lay.step[j]
        v = lay.v[j] + np.array([-0.5, -0.5, 0.5, 0.5, 0.0]) * py
        corners.append(lay.face.point(u, v))
    corners = np.concatenate(corners)
    assert corners[:, 0].max() < ORB_CUT
    # a ring whose cells all lie at x < 1.5 - 0.01 (their x at most r_ring + the patch) keeps
    # every cell
    clear = (lay.count > 0) & (np.abs(lay.radius) + 2 * px < ORB_CUT - 0.01)
    assert (kept[clear].sum(axis=1) == lay.count[clear]).all()
    share = (
        sum(
            lay.face.band_area(lay.v[j] - py / 2, lay.v[j] + py / 2, kept[j].sum() * lay.step[j])
            for j in range(len(lay.v))
        )
        / target.shape.face_areas["first.outer"]
    )
    assert layer.rough_share == pytest.approx(share, rel=1e-12)
    assert 0.85 < layer.rough_share < 1
    rng = np.random.default_rng(5)
    n = 16
    cells = [c for c in layer.cells() if lay.radius[c[0]] > 0.5]
    starts, directions = [], []
    for _ in range(n):
        j, _i, _v, phi = cells[rng.integers(len(cells))]
        p = lay.face.point(phi + rng.uniform(-0.3, 0.3) * lay.step[j], lay.v[j])
        start = p * 3.05 / 3.0
        aim = np.array([rng.uniform(-1.5, 1.0), *rng.uniform(-1.5, 1.5, 2)])
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    starts, directions = np.array(starts), np.array(directions)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    world_starts = target.to_world(starts)
    r = geantino_run(data, primaries, world_starts, directions @ target.rotation.T, tmp_path)
    got = np.asarray(r.scores["track_length"]["orbcut"])
    expected = np.array(
        [_orb_less_box_path(o, d, layer) for o, d in zip(starts, directions, strict=True)]
    )
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    assert (expected > 0.3).all()


@pytest.mark.deep
def test_geantino_paths_through_the_seam_row_of_a_post_wall(gdml, tmp_path):
    """The post's wall on the disk (a union): the row of cells along the seam, which touches
    the disk, keeps its patches (its bounding box proves it; every cell is kept); geantinos
    aimed through that row into the post and on into the disk: Geant4's track length equals
    the analytic path in the disk plus the post plus the path in the bent patch bodies near the
    crossing, to 1e-9 mm (deep: ~7 s)."""
    data = config(gdml, {"stack": ["second.outer"]}, FINE, output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    (layer,) = scene.layers
    lay = layer.ring_layout
    assert (layer.mask == (layer.patch_map.variants >= 0) & layer.mask).all()
    assert layer.mask.sum() == lay.count.sum()  # the seam row included
    target = scene.target("stack")
    rng = np.random.default_rng(17)
    n = 10
    phi = rng.uniform(0, 2 * np.pi, n)
    z = rng.uniform(5.12, 5.45, n)
    local = np.column_stack([7.3 * np.cos(phi), 7.3 * np.sin(phi), z])
    way = np.column_stack([-np.cos(phi + 0.1), -np.sin(phi + 0.1), np.full(n, -0.3)])
    way /= np.linalg.norm(way, axis=1, keepdims=True)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, target.to_world(local), way @ target.rotation.T, tmp_path)
    got = np.asarray(r.scores["track_length"]["stack"])
    crossed = 0
    for k in range(n):
        o, d = local[k], way[k]
        expected = _tube_path(o, d, (0, 0), 10.0, -5.0, 5.0) + _tube_path(o, d, (0, 0), 7.0, 5, 15)
        a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
        t = (-b - math.sqrt(b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - 49))) / (2 * a)
        hit = o + t * d  # where the ray meets the wall
        assert 5.0 < hit[2] < 5.0 + layer.patch_size[1]  # in the seam row
        at = layer.target.to_local(target.to_world(hit[None]))[0]  # the post's own frame
        tri = wall_patches_near(layer, target, at, 2 / 7)
        in_patches = mesh_path(o, d, tri, edge=1e-12, merge=1e-10)
        crossed += in_patches > 0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2


def _hex_less_box_path(o: np.ndarray, d: np.ndarray) -> float:
    """Path of a ray (solid frame) in the hexagonal prism (side planes at distance 8 mm, their
    normals at 30 + 60 k degrees, |z| < 10) less the box x, y > 4 mm."""
    t0, t1 = 0.0, np.inf
    planes = [
        (np.array([math.cos(a), math.sin(a), 0.0]), 8.0) for a in np.radians(30 + 60 * np.arange(6))
    ]
    planes += [(np.array([0.0, 0.0, 1.0]), 10.0), (np.array([0.0, 0.0, -1.0]), 10.0)]
    for n, h in planes:
        dn, on = n @ d, n @ o
        if abs(dn) < 1e-15:
            if on > h:
                return 0.0
            continue
        t = (h - on) / dn
        t0, t1 = (max(t0, t), t1) if dn < 0 else (t0, min(t1, t))
    if t1 <= t0:
        return 0.0
    b0, b1 = _box_path(o, d, (HEX_CUT, HEX_CUT, -20), (HEX_CUT + 20, HEX_CUT + 20, 20))
    return (t1 - t0) - max(0.0, min(t1, b1) - max(t0, b0))


def test_a_face_of_six_planes_on_a_boolean_takes_a_layer_per_plane(gdml, tmp_path):
    """The six sides of a G4Polyhedra less a box over one corner: one layer per plane, each
    keeping the cells on the boolean's surface (clear of the box, which cuts two of them); the
    planes' rough shares add up to the kept cells' area over the face's estimated area, and
    the flat rest is drawn once for all planes (its share of the source, 4 sigma); geantinos
    from just outside kept cells into the prism: Geant4's track length equals the analytic
    path in the prism less the box plus the path in the patch bodies, to 1e-9 mm."""
    data = config(gdml, {"hexcut": ["first.outer"]}, output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    layers = scene.layers
    assert len(layers) == 6
    target = scene.target("hexcut")
    normals = np.array([la.frame.normal @ target.rotation for la in layers])
    angles = np.sort(np.degrees(np.arctan2(normals[:, 1], normals[:, 0])) % 360)
    np.testing.assert_allclose(angles, 30 + 60 * np.arange(6), atol=1e-9)
    px, py = layers[0].patch_size
    area = target.shape.face_areas["first.seg_1"]
    kept = sum(int((la.cell_variants >= 0).sum()) for la in layers)
    assert sum(la.rough_share for la in layers) == pytest.approx(kept * px * py / area, rel=1e-12)
    assert 0.9 < sum(la.rough_share for la in layers) < 1
    for la in layers:  # kept cells clear of the box: their corners at x <= 4 or y <= 4
        c = la.cell_centres()[la.cell_variants >= 0]
        off = np.array([[sx * px / 2, sy * py / 2] for sx in (-1, 1) for sy in (-1, 1)])
        xy = (c[:, None, :] + off[None]).reshape(-1, 2)
        q = target.to_local(la.frame.to_world(np.column_stack([xy, np.zeros(len(xy))])))
        assert ((q[:, 0] <= HEX_CUT + 1e-9) | (q[:, 1] <= HEX_CUT + 1e-9)).reshape(-1, 4).all()
    n = 4000
    p = make_source(cfg, scene).primaries(np.random.default_rng(4), 0, n)
    geo = source_geometry(cfg, scene)
    tops = sum(layer_sampler(la).area for la in layers)
    flat = area - kept * px * py
    assert geo["area_mm2"] == pytest.approx(tops + flat, rel=1e-9)
    on_flat = p.extra["patch"] < 0
    share = flat / geo["area_mm2"]
    assert abs(on_flat.mean() - share) < 4 * math.sqrt(share * (1 - share) / n)
    local = target.to_local(p.position[on_flat])
    assert np.abs(target.shape.signed_distance(local)).max() < 1e-9
    rng = np.random.default_rng(9)
    starts, directions = [], []
    for k in range(12):
        la = layers[k % 6]
        cells = np.argwhere(la.cell_variants >= 0)
        j, i = cells[rng.integers(len(cells))]
        c = la.cell_centres()[j, i] + rng.uniform(-0.2, 0.2, 2)
        start = la.frame.to_world(np.array([*c, 0.03]))
        aim = target.to_world(np.array([[*rng.uniform(-4, 3, 2), rng.uniform(-9, 9)]]))[0]
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, len(starts))
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    got = np.asarray(r.scores["track_length"]["hexcut"])
    crossed = 0
    for k, (o, d) in enumerate(zip(starts, directions, strict=True)):
        in_patches = sum(flat_patches_path(la, o, d) for la in layers)
        crossed += in_patches > 0
        expected = _hex_less_box_path(target.to_local(o[None])[0], d @ target.rotation)
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= 6
