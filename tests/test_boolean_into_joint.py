"""``into: true`` on faces of a boolean's constituents that share an edge, and under parts that
stand on a cut face (score4.world.boolean_layers.into_joint, score4.world.boolean_modes): the
post's wall and top are cut together as on a plain tube (the wall's layer ends on the top's cut,
the top's cells and flat rest within the thinner post); the post's wall and the disk's top it
stands on are cut together (the post grows down into the disk's cut, thinner by its wall's cut,
and the wall's layer runs down to the cut: no vacuum ring at the post's foot); a cone or a
polycone standing on a box's face grows down as the prism of its foot (a cylinder of the foot's
radius), whatever the slope of its wall. Against paths, volumes and point sets written here from
the solids' dimensions."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from test_boolean_faces import _box_path, _tube_path

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.shapes import (
    BooleanShape,
    G4Box,
    G4Cons,
    G4Polycone,
    G4Polyhedra,
    G4Tubs,
    Transform,
)
from score4.source.build import make_source
from score4.world.boolean_modes import standing_cuts
from score4.world.resolve import build_scene

from helpers.boolean_worlds import copper_world_text
from helpers.g4_geometry_check import assert_no_overlaps
from helpers.geantinos import geantino_config, geantino_run, rough_targets
from helpers.ray_trace import patches_path, revolved_path

# one worker per module: its boolean solids' face areas are estimated once (cold: ~2 s each)
pytestmark = pytest.mark.xdist_group("into-joint")

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
#: 0.4 mm patches, fine enough to bend onto the cones (r 5 to 8 mm)
FINE = {**PYRAMIDS, "width": "80 um"}
#: where the solids stand (``stack`` twice: two pairs of faces)
AT = {
    "stack": (0.0, -40.0, 0.0),
    "stack2": (0.0, -70.0, 0.0),
    "lamp": (40.0, 0.0, 0.0),
    "vase": (0.0, 40.0, 0.0),
    "bottle": (-40.0, 0.0, 0.0),
    "block": (40.0, 40.0, 0.0),
}
#: volume -> its into faces in each case
CASES = {
    "top": ("stack", ["second.outer", "second.+z"]),  # the post's wall and top
    "foot": ("stack2", ["first.+z", "second.outer"]),  # the disk's top and the post's wall
    "lamp": ("lamp", ["first.+z"]),  # under a cone narrowing upward (r 8 -> 5 mm)
    "vase": ("vase", ["first.+z"]),  # under a cone widening upward (r 5 -> 8 mm)
    "bottle": ("bottle", ["first.+z"]),  # under a polycone: a cylinder, then a cone
}
#: the radius of the foot of the part standing on the box's top (z = 10 mm) and that part's
#: pieces above it: (r1, r2, z1, z2) of each cone (or cylinder) piece
PARTS = {
    "lamp": (8.0, [(8.0, 5.0, 10.0, 20.0)]),
    "vase": (5.0, [(5.0, 8.0, 10.0, 20.0)]),
    "bottle": (6.0, [(6.0, 6.0, 10.0, 14.0), (6.0, 3.0, 14.0, 20.0)]),
}


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """``stack``, ``stack2``: a disk (r 10 mm, 10 mm high) with a post (r 7 mm, 10 mm high) on
    it; ``lamp``, ``vase``: a 20 mm box with a cone on its +z face (r 8 mm at its foot and 5 mm
    at its top; 5 and 8 mm), 10 mm high; ``bottle``: the box with a polycone on it (r 6 mm up
    to 4 mm, then narrowing to 3 mm at 10 mm); ``block``: the disk with a 6 mm box on it.
    Written as GDML text."""
    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    stack = "".join(
        f"""<tube name="{v}_a" rmin="0" rmax="10" z="10" {full}/>
<tube name="{v}_b" rmin="0" rmax="7" z="10" {full}/>
<union name="{v}_s"><first ref="{v}_a"/><second ref="{v}_b"/>
  <position name="{v}_p" x="0" y="0" z="10" unit="mm"/></union>"""
        for v in ("stack", "stack2")
    )
    cones = "".join(
        f"""<box name="{v}_a" x="20" y="20" z="20" lunit="mm"/>
<cone name="{v}_b" rmin1="0" rmax1="{r1}" rmin2="0" rmax2="{r2}" z="10" {full}/>
<union name="{v}_s"><first ref="{v}_a"/><second ref="{v}_b"/>
  <position name="{v}_p" x="0" y="0" z="15" unit="mm"/></union>"""
        for v, r1, r2 in (("lamp", 8, 5), ("vase", 5, 8))
    )
    solids = f"""
<box name="world_s" x="300" y="300" z="200" lunit="mm"/>{stack}{cones}
<box name="bottle_a" x="20" y="20" z="20" lunit="mm"/>
<polycone name="bottle_b" {full}>
  <zplane z="0" rmin="0" rmax="6"/><zplane z="4" rmin="0" rmax="6"/>
  <zplane z="10" rmin="0" rmax="3"/></polycone>
<union name="bottle_s"><first ref="bottle_a"/><second ref="bottle_b"/>
  <position name="bottle_p" x="0" y="0" z="10" unit="mm"/></union>
<tube name="block_a" rmin="0" rmax="10" z="10" {full}/>
<box name="block_b" x="6" y="6" z="10" lunit="mm"/>
<union name="block_s"><first ref="block_a"/><second ref="block_b"/>
  <position name="block_p" x="0" y="0" z="10" unit="mm"/></union>"""
    text = copper_world_text(solids, AT)
    path = tmp_path_factory.mktemp("into_joint") / "into_joint.gdml"
    path.write_text(text)
    return path


def config(gdml: Path, cases: list[str], **extra) -> dict:
    """One target per case, its faces rough with ``into``; the source on the first case's
    faces."""
    volume, faces = CASES[cases[0]][:2]
    targets = [rough_targets({CASES[c][0]: CASES[c][1]}, into=True)[0] for c in cases]
    return geantino_config(gdml, {"p": PYRAMIDS, "f": FINE}, targets, (volume, faces), **extra)


def _depths(scene, case: str) -> dict[str, float]:
    """How deep each into face of a case is cut (mm): a wall's cut, a flat layer's
    thickness."""
    volume, faces = CASES[case]
    out = {}
    for face in faces:
        layer = scene.layer(volume, face)
        out[face] = getattr(layer, "into_cut", 0.0) or layer.thickness
    return out


def _inside(case: str, cut: dict[str, float], q: np.ndarray) -> np.ndarray:
    """Points (the target's frame) in the solid cut for the case, from its dimensions: the
    disk and the post (thinner by its wall's cut, shorter by its top's, grown down by the
    disk's); the box, its top cut, and the part on it with the prism of its foot under it."""
    r, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2]
    if case in ("top", "foot"):
        wall, top, disk = (cut.get(f, 0.0) for f in ("second.outer", "second.+z", "first.+z"))
        post = (r < 7.0 - wall) & (z > 5.0 - disk) & (z < 15.0 - top)
        return ((r < 10.0) & (z > -5.0) & (z < 5.0 - disk)) | post
    t = cut["first.+z"]
    foot, pieces = PARTS[case]
    box = (np.abs(q[:, :2]) < 10.0).all(axis=1) & (z > -10.0) & (z < 10.0 - t)
    out = box | ((r < foot) & (z > 10.0 - t) & (z < 10.0))
    for r1, r2, z1, z2 in pieces:
        out |= (z > z1) & (z < z2) & (r < r1 + (r2 - r1) * (z - z1) / (z2 - z1))
    return out


def _near_edges(case: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points (the target's frame) within 0.1 mm of the edges the case cuts together
    (the post's top rim; its foot) or of the foot of the part on the box."""
    if case == "top":
        r0, z0 = 7.0, 15.0
    elif case == "foot":
        r0, z0 = 7.0, 5.0
    else:
        r0, z0 = PARTS[case][0], 10.0
    r = rng.uniform(r0 - 0.1, r0 + 0.1, n)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), rng.uniform(z0 - 0.1, z0 + 0.1, n)])


def check_cut(scene, case: str, rng: np.random.Generator) -> None:
    """The volume score4 tracks in (``inside_target``: the cut solid and the patches) is the
    solid cut from its dimensions plus the patch bodies, at 20 000 points near the edges; the
    source on the faces stays in it."""
    volume = CASES[case][0]
    target = scene.target(volume)
    q = _near_edges(case, 20_000, rng)
    world = target.to_world(q)
    in_patch = np.zeros(len(q), dtype=bool)
    for layer in scene.layers_of(volume):
        in_patch |= layer.contains(world)
    expected = _inside(case, _depths(scene, case), q) | in_patch
    got = scene.inside_target(volume, world)
    assert (got == expected).all(), f"{int((got != expected).sum())} points differ"
    assert 0 < in_patch.sum() < len(q)


@pytest.fixture(scope="module")
def scenes(gdml) -> dict:
    """The scene of each case (built once: its face areas cost ~2 s each, cold)."""
    return {}


def _scene(scenes: dict, gdml: Path, case: str):
    if case not in scenes:
        scenes[case] = build_scene(parse_config(config(gdml, [case])))
    return scenes[case]


@pytest.mark.deep
def test_the_post_wall_and_top_are_cut_together(gdml, scenes):
    """into on the post's wall and top: the wall's layer lies on the thinner post's wall and
    ends where the top's cut begins (5 - top's cut in the post's frame); the top's cells and
    flat rest lie within the thinner post (r <= 7 - wall's cut), its envelope is the old top's
    ring; the volume is the joint cut's near the rim (deep: ~8 s CPU with a cold cache, the
    face areas of four boolean solids)."""
    scene = _scene(scenes, gdml, "top")
    wall, top = scene.layer("stack", "second.outer"), scene.layer("stack", "second.+z")
    c, t = wall.into_cut, top.thickness
    face = wall.ring_layout.face
    assert face.rz1 == pytest.approx((7.0 - c, -5.0), abs=1e-12)
    assert face.rz2 == pytest.approx((7.0 - c, 5.0 - t), abs=1e-12)
    assert top.rest_radii == pytest.approx((0.0, 7.0 - c), abs=1e-12)
    assert top.ring == (0.0, 7.0)
    centres = top.cell_centres()[top.mask]
    far = np.hypot(np.abs(centres[:, 0]) + 0.25, np.abs(centres[:, 1]) + 0.25)
    assert far.max() <= 7.0 - c
    assert len(centres) > 400
    check_cut(scene, "top", np.random.default_rng(1))
    drawn = make_source(parse_config(config(gdml, ["top"])), scene).primaries(
        np.random.default_rng(3), 0, 500
    )
    assert scene.inside_target("stack", drawn.position).all()


def check_foot(scene) -> None:
    """The post's wall and the disk's top: the wall's layer runs down to the disk's cut (its
    face from z = -5 - the disk's cut in the post's frame, on the thinner post), so the ring
    under it, in the old disk's slab, lies in its shell (not a vacuum ring); the disk's kept
    cells lie outside the old post (their columns clear of the wall's layer)."""
    wall, disk = scene.layer("stack2", "second.outer"), scene.layer("stack2", "first.+z")
    c, t = wall.into_cut, disk.thickness
    face = wall.ring_layout.face
    assert face.rz1 == pytest.approx((7.0 - c, -5.0 - t), abs=1e-12)
    assert face.rz2 == pytest.approx((7.0 - c, 5.0), abs=1e-12)
    rng = np.random.default_rng(4)
    n = 2000
    r, phi = rng.uniform(7.0 - c, 7.0, n), rng.uniform(0.0, 2 * np.pi, n)
    ring = np.column_stack([r * np.cos(phi), r * np.sin(phi), rng.uniform(5.0 - t, 5.0, n)])
    assert wall.in_shell(scene.target("stack2").to_world(ring)).all()
    centres = disk.cell_centres()[disk.mask]
    axis = disk.frame.to_local(scene.target("stack2").to_world(np.array([[0.0, 0.0, 5.0]])))
    gap = np.maximum(np.abs(centres - axis[0, :2]) - 0.25, 0.0)
    assert np.hypot(gap[:, 0], gap[:, 1]).min() >= 7.0 - 1e-9
    assert len(centres) > 100


def test_the_post_wall_runs_down_into_the_cut_of_the_disk_it_stands_on(gdml, scenes):
    """into on the disk's top and on the post's wall (refused by session 11: built before
    that, it left a vacuum ring at the post's foot): the post grows down into the disk's cut,
    thinner by its wall's cut, and its wall's layer runs down with it (check_foot); the volume
    is the joint cut's near the foot, and the source stays in it."""
    scene = _scene(scenes, gdml, "foot")
    check_foot(scene)
    check_cut(scene, "foot", np.random.default_rng(2))
    drawn = make_source(parse_config(config(gdml, ["foot"])), scene).primaries(
        np.random.default_rng(3), 0, 500
    )
    assert scene.inside_target("stack2", drawn.position).all()


@pytest.mark.deep
def test_the_foot_check_fails_on_the_wall_laid_out_alone(gdml, monkeypatch):
    """The same pair with the wall laid out on its own cut (the joint layout skipped): its
    layer ends at the old foot, the ring under it is vacuum, and check_foot fails (deep)."""
    import score4.world.boolean_layers as boolean_layers

    monkeypatch.setattr(boolean_layers, "joint_layout", lambda t, layers, w, fixed=None: layers)
    scene = build_scene(parse_config(config(gdml, ["foot"])))
    with pytest.raises(AssertionError):
        check_foot(scene)


@pytest.mark.parametrize(
    "case",
    [
        "lamp",
        # deep: each solid's face areas cost ~2-4 s CPU with a cold cache
        pytest.param("vase", marks=pytest.mark.deep),
        pytest.param("bottle", marks=pytest.mark.deep),
    ],
)
def test_a_swept_part_grows_down_as_the_prism_of_its_foot(gdml, scenes, case):
    """into on the box's top, where a cone (narrowing or widening upward) or a polycone stands:
    the part grows down into the cut as the cylinder of its foot's radius (a G4GenericPolycone
    of its contour with the foot moved down, the wall above it kept), so the slab under the
    foot stays in the volume and the slab around it is cut; the volume near the foot is that
    solid's (with the patches), and the source stays in it."""
    scene = _scene(scenes, gdml, case)
    (layer,) = scene.layers_of(case)
    cut = layer.on_boolean.shape
    part = cut.second
    poly, _ = part.shape.contour()
    low = poly[np.abs(poly[:, 1] - poly[:, 1].min()) < 1e-12]
    base = cut.transform.translation[2] + part.transform.translation[2]  # the part's frame
    assert base + poly[:, 1].min() == pytest.approx(10.0 - layer.thickness, abs=1e-12)
    assert low[:, 0].max() == pytest.approx(PARTS[case][0], abs=1e-12)
    if case != "bottle":  # the cone's wall starts from the foot's rim on the face (the
        # polycone's cylinder runs on down: no corner there)
        at_face = poly[np.abs(base + poly[:, 1] - 10.0) < 1e-12]
        assert at_face[:, 0].max() == pytest.approx(PARTS[case][0], abs=1e-12)
    check_cut(scene, case, np.random.default_rng(5))
    drawn = make_source(parse_config(config(gdml, [case])), scene).primaries(
        np.random.default_rng(3), 0, 300
    )
    assert scene.inside_target(case, drawn.position).all()


@pytest.mark.deep
@pytest.mark.parametrize("case", ["lamp", "vase"])
def test_the_prism_check_fails_on_a_cone_grown_along_its_wall(gdml, case, monkeypatch):
    """The same with the cone grown down along its wall's line (its foot moved with the
    neighbours' lines kept, as a subtracted cone's floor grows): the lamp's foot spreads over
    the cut slab around it, the vase's leaves a vacuum ring under its rim, and check_cut
    fails."""
    import score4.world.boolean_modes as boolean_modes

    monkeypatch.setattr(boolean_modes, "straight_feet", lambda leaf, feet: True)
    scene = build_scene(parse_config(config(gdml, [case])))
    with pytest.raises(AssertionError, match="points differ"):
        check_cut(scene, case, np.random.default_rng(5))


def _path(case: str, cut: dict[str, float], o: np.ndarray, d: np.ndarray) -> float:
    """Path of the ray o + s d (the target's frame) in the cut solid, from its dimensions."""
    if case in ("top", "foot"):
        wall, top, disk = (cut.get(f, 0.0) for f in ("second.outer", "second.+z", "first.+z"))
        return _tube_path(o, d, (0, 0), 10.0, -5.0, 5.0 - disk) + _tube_path(
            o, d, (0, 0), 7.0 - wall, 5.0 - disk, 15.0 - top
        )
    t = cut["first.+z"]
    t0, t1 = _box_path(o, d, (-10, -10, -10), (10, 10, 10 - t))
    total = t1 - t0 + _tube_path(o, d, (0, 0), PARTS[case][0], 10.0 - t, 10.0)
    for r1, r2, z1, z2 in PARTS[case][1]:
        cone = G4Cons(0.0, r1, 0.0, r2, (z2 - z1) / 2)
        total += revolved_path(o - np.array([0.0, 0.0, (z1 + z2) / 2]), d, cone)
    return total


def _volume(case: str, cut: dict[str, float]) -> float:
    """The cut solid's volume from its dimensions (mm3)."""
    if case in ("top", "foot"):
        wall, top, disk = (cut.get(f, 0.0) for f in ("second.outer", "second.+z", "first.+z"))
        return math.pi * (100.0 * (10.0 - disk) + (7.0 - wall) ** 2 * (10.0 - top + disk))
    t = cut["first.+z"]
    foot, pieces = PARTS[case]
    out = 400.0 * (20.0 - t) + math.pi * foot**2 * t
    for r1, r2, z1, z2 in pieces:
        out += math.pi * (z2 - z1) / 3 * (r1 * r1 + r1 * r2 + r2 * r2)
    return out


def _rays(case: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` rays (the target's frame) from outside the edge the case cuts, in through it: from
    0.5 mm outside the post's rim (its top's, its foot's) to within 50 um of it and on across
    the post; from 1 um over the box's top, 1.8 mm off the foot's rim: half of them low across
    the box's layer (aimed 10 um deep, 0.5 mm off the rim) and on through the slab under the
    foot, half to 1 mm inside the rim into the part just above the face."""
    phi = rng.uniform(0.0, 2 * np.pi, n)
    c, s = np.cos(phi), np.sin(phi)
    if case in ("top", "foot"):
        r0, z0 = 7.0, (15.0 if case == "top" else 5.0)
        start_rz = np.array([r0, z0]) + 0.5 * rng.uniform(0.8, 1.2, (n, 2))
        aim_rz = np.array([r0, z0]) + rng.uniform(-0.05, 0.05, (n, 2))
        aim_rz[::2, 1] = z0 - 0.005  # half of them through the slab under the foot or the top
        aim_rz[:, 0] -= 3.0  # on inward, across the post
    else:
        r0, z0 = PARTS[case][0], 10.0
        start_rz = np.column_stack([r0 + rng.uniform(1.6, 2.0, n), np.full(n, z0 + 0.001)])
        aim_rz = np.column_stack([np.full(n, r0 - 1.0), np.full(n, z0 + 0.5)])
        aim_rz[::2] = [r0 + 0.5, z0 - 0.01]  # through the pyramids, on under the foot
    start = np.column_stack([start_rz[:, 0] * c, start_rz[:, 0] * s, start_rz[:, 1]])
    aim = np.column_stack([aim_rz[:, 0] * c, aim_rz[:, 0] * s, aim_rz[:, 1]])
    ways = aim - start
    return start, ways / np.linalg.norm(ways, axis=1, keepdims=True)


@pytest.mark.deep
@pytest.mark.parametrize("case", list(CASES))
def test_geantino_paths_through_joint_cuts(gdml, scenes, case, tmp_path):
    """Geantinos from outside the edge each case cuts, in through it: Geant4's track length in
    the target (the boolean rebuilt with its constituents cut together, the parts grown down)
    equals the path in the cut solid from its dimensions plus the paths in every layer's patch
    bodies, to 1e-9 mm; Geant4's volume of the rebuilt union less its layers is the cut
    solid's (exact for touching parts; deep: ~10-40 s each)."""
    data = config(gdml, [case], output={"track_length": True})
    cfg = parse_config(data)
    scene = _scene(scenes, gdml, case)
    volume = CASES[case][0]
    target = scene.target(volume)
    n = 12
    local, ways = _rays(case, n, np.random.default_rng(11))
    starts, directions = target.to_world(local), ways @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    result = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(result.scores["track_length"][volume])
    cut = _depths(scene, case)
    crossed = 0
    for k in range(n):
        in_patches = sum(
            patches_path(starts[k], directions[k], layer, 30.0) for layer in scene.layers_of(volume)
        )
        crossed += in_patches > 0
        expected = _path(case, cut, local[k], ways[k])
        assert expected > 1.0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 3  # on the box, only the rays into the slab run through the layer
    (record,) = result.run["volumes"]
    g4_volume = record["volume_mm3"] - record["layer_volume_mm3"]
    assert g4_volume == pytest.approx(_volume(case, cut), rel=1e-9)


@pytest.mark.deep
def test_joint_cuts_pass_the_overlap_check(gdml, tmp_path):
    """`score4 geometry check` (Geant4's overlap check over the rebuilt unions and every
    layer's cells) finds no overlaps in a world of all five cases (deep: ~1 min)."""
    path = tmp_path / "into_joint.yaml"
    path.write_text(yaml.safe_dump(config(gdml, list(CASES))))
    assert_no_overlaps(path)


def _shallow_check(data: dict) -> tuple[bool, list[str]]:
    """In a spawned process: the world of ``data`` built with every into cut of its booleans
    in Geant4 a thousandth as deep (the layers where score4 lays them out), and Geant4's
    overlap check on it."""
    import score4.geometry.built as built_module
    from score4.geometry.check import check_placements
    from score4.geometry.world import build_world
    from score4.runner.run_plan import plan_run
    from score4.sim.runtime import import_geant4, redirect_native_output, resolve_physics

    real = built_module.boolean_cuts

    def shallow(layers, shape):
        return {face: depth * 1e-3 for face, depth in real(layers, shape).items()}

    built_module.boolean_cuts = shallow
    g4 = import_geant4(resolve_physics("lite"))
    with redirect_native_output(None):
        plan = plan_run(parse_config(data), physics=resolve_physics("lite"), source=False)
        world = build_world(g4, plan)
        report = check_placements(
            world.world, points=500, max_placements=20, layers=plan.scene.layers
        )
    return report.ok, report.overlaps


@pytest.mark.deep
def test_the_overlap_check_fails_on_a_shallow_cut(gdml):
    """The post's wall and the disk's top with Geant4's cuts a thousandth as deep: the layers'
    envelopes run into the solid, and the overlap check says so (deep: ~30 s)."""
    from helpers.spawn import run_in_spawned_process

    ok, overlaps = run_in_spawned_process(_shallow_check, config(gdml, ["foot"]))
    assert not ok
    assert overlaps


@pytest.mark.deep  # ~4 s CPU each with a cold cache (their boolean face areas)
@pytest.mark.parametrize(
    ("volume", "faces", "message"),
    [
        (
            "lamp",
            ["first.+z", "second.outer"],
            (
                "targets.0.rough: into: true on faces first.+z and second.outer of 'lamp': the "
                "part second of the union stands on face first.+z and grows down into its cut, "
                "and score4 cuts a face of such a part that meets its foot only on a G4Tubs, "
                "G4Cons or polycone with a full circle whose walls rise from the foot along its "
                "axis"
            ),
        ),
        (
            "block",
            ["first.+z", "second.+x"],
            (
                "targets.0.rough: into: true on faces first.+z and second.+x of 'block': the box "
                "second of the union stands on face first.+z and grows down into its cut (its "
                "face -z), and its side +x meets that foot"
            ),
        ),
    ],
)
def test_joint_cuts_score4_does_not_make_say_why(gdml, volume, faces, message):
    """A cone's wall and the box's top it stands on (grown down as the prism of its foot, its
    wall's cut would run on along its slope: one line naming both faces and the rule), a box
    post's side and the disk's top it grows down into (a vacuum notch along the foot)."""
    data = {
        **config(gdml, ["lamp"]),
        "targets": [
            {
                "volume": volume,
                "rough": [
                    {"face": f, "surface": "f" if "outer" in f else "p", "into": True}
                    for f in faces
                ],
            }
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": volume, "face": faces[0]},
        },
    }
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(data))
    assert str(err.value).startswith(message)
    assert "\n" not in str(err.value)


@pytest.mark.deep  # ~3 s CPU with a cold cache
def test_a_box_post_top_and_the_disk_top_it_stands_on_are_both_cut(gdml):
    """A box post's top and the disk's top under it (faces of the post that do not meet its
    foot): both cut (the post grown down and shorter), the volume near its foot and top the
    solid's from its dimensions."""
    data = {
        **config(gdml, ["lamp"]),
        "targets": [
            {
                "volume": "block",
                "rough": [
                    {"face": f, "surface": "p", "into": True} for f in ("first.+z", "second.+z")
                ],
            }
        ],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "block", "face": "first.+z"},
        },
    }
    scene = build_scene(parse_config(data))
    t_disk = scene.layer("block", "first.+z").thickness
    t_top = scene.layer("block", "second.+z").thickness
    rng = np.random.default_rng(6)
    q = np.column_stack(
        [rng.uniform(-4, 4, 20_000), rng.uniform(-4, 4, 20_000), rng.uniform(4.9, 15.1, 20_000)]
    )
    q[::2, 2] = rng.uniform(4.9, 5.1, 10_000)
    target = scene.target("block")
    world = target.to_world(q)
    in_patch = scene.layer("block", "first.+z").contains(world)
    in_patch |= scene.layer("block", "second.+z").contains(world)
    r, z = np.hypot(q[:, 0], q[:, 1]), q[:, 2]
    post = (np.abs(q[:, :2]) < 3.0).all(axis=1) & (z > 5.0 - t_disk) & (z < 15.0 - t_top)
    expected = ((r < 10.0) & (z > -5.0) & (z < 5.0 - t_disk)) | post | in_patch
    np.testing.assert_array_equal(scene.inside_target("block", world), expected)


def test_a_part_on_a_face_of_several_planes_is_refused():
    """A box standing on a side of a G4Polyhedra (a face of six planes): no part is grown down
    into such a face's cut, so one that meets its slab is refused in one line naming it (a part
    beside the polyhedra, off every side's slab, is not)."""
    hexagon = G4Polyhedra(0.0, 2 * np.pi, 6, (-5.0, 5.0), (0.0, 0.0), (10.0, 10.0))
    (side,) = ("first." + f for f in hexagon.resolve_faces("outer"))
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)  # on the side facing 30 degrees
    on = Transform(
        np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), 13.0 * np.array([c, s, 0])
    )
    shape = BooleanShape("union", hexagon, G4Box(3.0, 2.0, 2.0), on)
    with pytest.raises(ConfigError) as err:
        standing_cuts(shape, side, 0.02, "into")
    msg = str(err.value)
    assert msg.startswith(
        "into: another part of the union (the G4Box second) stands on this face (a face of 6 "
        "planes, and score4 grows a part down into the cut of a face of one plane only)"
    )
    assert "\n" not in msg
    away = BooleanShape("union", hexagon, G4Box(3.0, 2.0, 2.0), Transform(np.eye(3), [0, 0, 8.0]))
    assert standing_cuts(away, side, 0.02, "into") == {}


def test_a_cone_foot_extruded_is_the_prism_of_its_foot():
    """RevolvedShape.footed: a cone (r 8 mm at its foot, 5 at its top) with its foot pushed
    out by 0.02 mm is a G4GenericPolycone whose contour runs straight down from the foot's rim
    (the corner on the axis dropped), of the cone's volume plus the foot's disk times 0.02;
    cut on its top as well, the top moves down; a tube's foot is not a slanted wall's: both
    ways give the moved tube."""
    cone = G4Cons(0.0, 8.0, 0.0, 5.0, 5.0)
    grown, shift = cone.footed({}, {"-z": 0.02})
    np.testing.assert_allclose(grown.r, [0.0, 8.0, 8.0, 5.0, 0.0])
    np.testing.assert_allclose(grown.z, [-5.02, -5.02, -5.0, 5.0, 5.0])
    assert shift.tolist() == [0.0, 0.0, 0.0]
    exact = math.pi * 10.0 / 3 * (64 + 40 + 25) + math.pi * 64 * 0.02
    assert grown.volume == pytest.approx(exact, rel=1e-12)
    both, _ = cone.footed({"+z": 0.01}, {"-z": 0.02})
    assert max(both.z) == pytest.approx(4.99, abs=1e-12)
    tube, _ = G4Tubs(0.0, 7.0, 5.0).footed({}, {"-z": 0.02})
    np.testing.assert_allclose(tube.r, [0.0, 7.0, 7.0, 0.0])
    np.testing.assert_allclose(tube.z, [-5.02, -5.02, 5.0, 5.0])


def test_walls_sharing_an_edge_on_a_phi_segment_are_refused():
    """Two into walls that share an edge (a cylinder and the cone above it) on a polycone of
    three quarters of a circle standing on a box: no joint cut is made with a phi segment (as
    on a plain solid), one line naming both faces and the edge (the layers given as what
    joint_leaves reads of them: a face name and a thickness)."""
    from types import SimpleNamespace

    from score4.world.boolean_modes import joint_leaves

    bottle = G4Polycone(0.0, 1.5 * np.pi, (0.0, 4.0, 10.0), (0.0, 0.0, 0.0), (6.0, 6.0, 3.0))
    shape = BooleanShape("union", G4Box(10.0, 10.0, 10.0), bottle, Transform(np.eye(3), [0, 0, 10]))
    layers = [
        SimpleNamespace(config=SimpleNamespace(into=True, face_name=f"second.{f}"), thickness=0.02)
        for f in ("seg_1", "seg_2")
    ]
    target = SimpleNamespace(shape=shape, name="bottle")
    with pytest.raises(ConfigError) as err:
        joint_leaves(layers, target, "targets.0.rough")
    assert str(err.value).startswith(
        "targets.0.rough: into: true on faces second.seg_1 and second.seg_2 of 'bottle', faces "
        "of one G4Polycone of the boolean that share an edge (the circle r = 6 mm at z = 4 mm in "
        "its frame): score4 cuts such faces together on a G4Tubs, G4Cons or polycone with a "
        "full circle only"
    )
    full = replace(bottle, dphi=2 * np.pi)
    shape = BooleanShape("union", G4Box(10.0, 10.0, 10.0), full, Transform(np.eye(3), [0, 0, 10]))
    target = SimpleNamespace(shape=shape, name="bottle")
    joint = joint_leaves(layers, target, "targets.0.rough")
    assert joint == ({"second.": {}}, ["second.seg_1", "second.seg_2"])


@pytest.mark.deep
def test_joint_cuts_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The post's wall with the disk's top, and the box's top under the lamp's cone (a
    G4GenericPolycone grown as the prism of its foot), written by `score4 geometry export`:
    Geant4 reads the file back, and the file pyg4ometry reads and writes again, with the same
    geantino paths (volumes and points, 1e-9 mm) as the world score4 builds; most rays cross a
    patch (deep: ~1-2 min)."""
    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    cases = ["foot", "lamp"]
    data = config(gdml, cases)
    path = tmp_path / "into_joint.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "into_joint.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    scene = build_scene(parse_config(data))
    rays = []
    for k, case in enumerate(cases):
        target = scene.target(CASES[case][0])
        local, ways = _rays(case, 6, np.random.default_rng(30 + k))
        world, turned = target.to_world(local), ways @ target.rotation.T
        rays += [(o.tolist(), d.tolist()) for o, d in zip(world, turned, strict=True)]
    ours, back, relay = three_paths(path, out, rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= 6
