"""``into: true`` on curved faces of boolean constituents (score4.world.boolean_modes,
score4.geometry.boolean_cut): the wall of a post standing on a disk (a G4Tubs in a union), the
wall of a cone standing on a box (a G4Cons in a union), the sphere face of an orb less a box (a
G4Orb less a G4Box) and the bore a subtracted G4Cons leaves in a box. The constituent is made
thinner behind the face (the subtracted cone wider), the boolean rebuilt with it, and the layer
lies in the shell between the cut face and the old one; against paths and volumes written here
from the solids' dimensions."""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from test_boolean_faces import _box_path, _tube_path

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.shapes import G4Cons, G4Orb, G4Tubs
from score4.source.build import make_source
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.boolean_worlds import copper_world_text
from helpers.g4_geometry_check import assert_no_overlaps
from helpers.geantinos import geantino_config, geantino_run
from helpers.ray_trace import mesh_path, revolved_path, wall_patches_near

# one worker per module: its world is written and its boolean face areas estimated once
pytestmark = pytest.mark.xdist_group("into-curved")

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high (the post, r 7 mm)
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
#: 0.4 mm patches, fine enough to bend onto the cone (r 5 to 8 mm)
FINE = {**PYRAMIDS, "width": "80 um"}
#: 0.1 mm patches of 10 um pyramids, for the orb (r 3 mm)
SMALL = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
#: where the three solids stand; the post's and the cone's centres above their bases
AT = {
    "stack": (0.0, -40.0, 0.0),
    "lamp": (40.0, 0.0, 0.0),
    "orbcut": (0.0, 40.0, 0.0),
    "conebore": (-40.0, 0.0, 0.0),
    "pie": (-40.0, -40.0, 0.0),
}
POST_Z, CONE_Z = 10.0, 15.0
ORB_CUT = 1.5  # the orb (r 3 mm) less the half-space x > 1.5 mm
#: how far (mm) the rays go down over 6 mm inward: into the disk or the box below the post and the
#: cone; across the bore
DOWN = {"stack": 4.0, "lamp": 4.0, "conebore": 1.0, "pie": 4.0}
#: a point well inside each solid, away from the cut face (the disk, the box's corner, the
#: plate, the orb's far side, the box's corner around the bore)
DEEP = {
    "stack": (9.0, 0.0, 0.0),
    "lamp": (9.0, 9.0, 0.0),
    "pie": (0.0, -11.0, -7.0),
    "orbcut": (-2.0, 0.0, 0.0),
    "conebore": (9.5, 9.5, 0.0),
}
#: Geant4's volume of a union of parts that only touch is the sum of theirs (exact: 0 off); of
#: a subtraction, its own estimate (G4VSolid::EstimateCubicVolume, 10^6 points): 3.1e-5 off for
#: the orb, where the cut moves the volume by 9.8e-3; 7.8e-4 off for the cone bore, where the
#: cut moves it by 2.8e-3
VOLUME_REL = {"stack": 1e-12, "lamp": 1e-12, "orbcut": 1e-3, "conebore": 1.5e-3, "pie": 1e-12}


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """``stack``: a disk (r 10 mm, 10 mm high) with a post (r 7 mm, 10 mm high) on it;
    ``lamp``: a 20 mm box with a cone (r 8 mm at its foot, 5 mm at its top, 10 mm high) on its
    +z face; ``orbcut``: an orb (r 3 mm) less a box beyond x = 1.5 mm; ``conebore``: a 20 mm
    box less a cone along z (r 4 mm at z = -20 mm, 8 mm at z = 20 mm: 5 to 7 mm in the box);
    ``pie``: three quarters of a disk (a G4Tubs with a phi segment) on a plate. Written as GDML text
    (pyg4ometry's import alone takes seconds)."""
    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    solids = f"""
<box name="world_s" x="200" y="200" z="200" lunit="mm"/>
<tube name="stack_a" rmin="0" rmax="10" z="10" {full}/>
<tube name="stack_b" rmin="0" rmax="7" z="10" {full}/>
<union name="stack_s"><first ref="stack_a"/><second ref="stack_b"/>
  <position name="stack_p" x="0" y="0" z="{POST_Z}" unit="mm"/></union>
<box name="lamp_a" x="20" y="20" z="20" lunit="mm"/>
<cone name="lamp_b" rmin1="0" rmax1="8" rmin2="0" rmax2="5" z="10" {full}/>
<union name="lamp_s"><first ref="lamp_a"/><second ref="lamp_b"/>
  <position name="lamp_p" x="0" y="0" z="{CONE_Z}" unit="mm"/></union>
<orb name="orbcut_a" r="3" lunit="mm"/>
<box name="orbcut_b" x="10" y="10" z="10" lunit="mm"/>
<subtraction name="orbcut_s"><first ref="orbcut_a"/><second ref="orbcut_b"/>
  <position name="orbcut_p" x="{ORB_CUT + 5}" y="0" z="0" unit="mm"/></subtraction>
<box name="conebore_a" x="20" y="20" z="20" lunit="mm"/>
<cone name="conebore_b" rmin1="0" rmax1="4" rmin2="0" rmax2="8" z="40" {full}/>
<subtraction name="conebore_s"><first ref="conebore_a"/><second ref="conebore_b"/></subtraction>
<tube name="pie_a" rmin="0" rmax="10" z="10" startphi="0" deltaphi="270" aunit="deg" lunit="mm"/>
<box name="pie_b" x="24" y="24" z="4" lunit="mm"/>
<union name="pie_s"><first ref="pie_a"/><second ref="pie_b"/>
  <position name="pie_p" x="0" y="0" z="-7" unit="mm"/></union>"""
    text = copper_world_text(solids, AT)
    path = tmp_path_factory.mktemp("into_curved") / "into_curved.gdml"
    path.write_text(text)
    return path


#: volume -> (face, surface) of each case
CASES = {
    "stack": ("second.outer", PYRAMIDS),
    "lamp": ("second.outer", FINE),
    "orbcut": ("first.outer", SMALL),
    "conebore": ("second.outer", FINE),  # the bore a subtracted G4Cons leaves
    "pie": ("first.outer", PYRAMIDS),  # the wall of a G4Tubs with a phi segment
}


def config(gdml: Path, rough: dict[str, list[str]], **extra) -> dict:
    volume, faces = next(iter(rough.items()))
    targets = [
        {"volume": v, "rough": [{"face": f, "surface": v, "into": True} for f in fs]}
        for v, fs in rough.items()
    ]
    return geantino_config(
        gdml, {v: CASES[v][1] for v in rough}, targets, (volume, faces[0]), **extra
    )


def _one(gdml: Path, volume: str, **extra) -> dict:
    return config(gdml, {volume: [CASES[volume][0]]}, **extra)


@pytest.mark.parametrize(
    "volume",
    [
        "stack",
        "lamp",
        "pie",
        pytest.param("orbcut", marks=pytest.mark.deep),  # ~5 s: 7729 sphere cells
        pytest.param("conebore", marks=pytest.mark.deep),  # ~3 s: 4687 cells
    ],
)
def test_into_a_curved_face_cuts_the_constituent_behind_it(gdml, volume):
    """The constituent behind the face is made thinner by the layer's cut (the post's and the
    orb's radius less it, the cone's wall moved along its normal by it; the subtracted cone
    grows by it), the layer's face is
    the cut constituent's, its kept cells lie on the cut boolean's surface (proven as on any
    boolean face: a point a hair outside each kept cell's centre is outside the cut solid, a
    hair inside is in it), the shell between the cut face and the old one is no longer in the
    volume unless in a patch, the layer's top reaches the old face, the other parts stay in
    the volume, and the source on the face stays in it."""
    scene = build_scene(parse_config(_one(gdml, volume)))
    (layer,) = scene.layers
    assert isinstance(layer, CurvedRoughLayer)
    target = scene.target(volume)
    on = layer.on_boolean
    leaf = on.clip.leaf
    old = target.shape.face_clip(CASES[volume][0]).leaf
    c = layer.into_cut
    assert layer.thickness <= c <= layer.thickness * (1 + 1e-6)
    if isinstance(old, G4Tubs):
        assert leaf == dataclasses.replace(old, rmax=old.rmax - c)
    elif isinstance(old, G4Cons):  # the wall moved by c along its normal, the ends kept (a
        # subtracted cone grows)
        slope = math.hypot(old.rmax1 - old.rmax2, 2 * old.dz) / (2 * old.dz)
        sign = -1.0 if on.clip.flipped else 1.0
        assert leaf.dz == old.dz
        assert leaf.rmax1 == pytest.approx(old.rmax1 - sign * c * slope, abs=1e-12)
        assert leaf.rmax2 == pytest.approx(old.rmax2 - sign * c * slope, abs=1e-12)
    else:
        assert isinstance(old, G4Orb)
        assert leaf == G4Orb(old.r - c)
    cells = layer.cells()
    assert len(cells) > 100
    lay = layer.ring_layout
    points = np.array([lay.face.point(phi, lay.v[j]) for j, _i, _v, phi in cells])
    world = layer.target.to_world(points)
    on_leaf = on.clip.transform.inverse_apply(target.to_local(world))
    np.testing.assert_allclose(leaf.signed_distance(on_leaf), 0.0, atol=1e-12)  # the cut face
    normal = (
        layer.target.rotation
        @ np.array([lay.face.normal(phi, lay.v[j]) for j, _i, _v, phi in cells]).T
    )
    local = on.transform.inverse_apply(world)
    n_local = normal.T @ target.rotation
    assert (on.shape.inside(local + 1e-6 * n_local) == 0).all()
    assert (on.shape.inside(local - 1e-6 * n_local) == 2).all()
    # in the old shell: out of the volume but for the patches; just under it: in
    rng = np.random.default_rng(5)
    du, dv = rng.uniform(-0.5, 0.5, (2, len(cells)))
    py = layer.patch_size[1]
    spread = np.array(
        [
            lay.face.point(phi + a * lay.step[j], lay.v[j] + b * py)
            + c / 2 * lay.face.normal(phi + a * lay.step[j], lay.v[j] + b * py)
            for (j, _i, _v, phi), a, b in zip(cells, du, dv, strict=True)
        ]
    )
    mid = layer.target.to_world(spread)
    inside = scene.inside_target(volume, mid)
    np.testing.assert_array_equal(inside, layer.contains(mid))
    assert 0 < inside.sum() < len(mid)
    assert scene.inside_target(volume, world - 1e-3 * normal.T).all()
    top = world + normal.T * (c + 1e-7)  # beyond the old face
    assert not scene.inside_target(volume, top).any()
    assert 0.8 < layer.rough_share <= 1.0
    # the other parts stay whole (the layer's own cut solid does not hold them)
    assert scene.inside_target(volume, target.to_world(np.array([DEEP[volume]]))).all()
    # the source on the face (the rough cells' tops and the cut face's flat rest) stays in it
    cfg = parse_config(_one(gdml, volume))
    drawn = make_source(cfg, scene).primaries(np.random.default_rng(3), 0, 500).position
    assert scene.inside_target(volume, drawn).all()


def _in_cube(o: np.ndarray, d: np.ndarray, half: float) -> float:
    """Path of the ray o + t d (t > 0) in the cube |x|, |y|, |z| < half."""
    t0, t1 = _box_path(o, d, (-half, -half, -half), (half, half, half))
    return t1 - t0


def _orb_less_half_space(o: np.ndarray, d: np.ndarray, r: float) -> float:
    """Path of the ray o + t d (t > 0) in the orb of radius r less x > ORB_CUT."""
    b, c = o @ d, o @ o - r * r
    disc = b * b - c
    if disc <= 0:
        return 0.0
    t1, t2 = max(-b - math.sqrt(disc), 0.0), -b + math.sqrt(disc)
    if abs(d[0]) > 1e-15:
        tc = (ORB_CUT - o[0]) / d[0]
        t1, t2 = (t1, min(t2, tc)) if d[0] > 0 else (max(t1, tc), t2)
    elif o[0] > ORB_CUT:
        return 0.0
    return max(t2 - t1, 0.0)


def _solid_path(volume: str, layer, o: np.ndarray, d: np.ndarray) -> float:
    """Path of a ray (the target's frame) in the cut boolean, from its dimensions: the disk plus
    the thinner post; the box plus the cut cone (traced as a solid of revolution); the smaller
    orb less the half-space."""
    c = layer.into_cut
    if volume == "stack":
        return _tube_path(o, d, (0, 0), 10.0, -5, 5) + _tube_path(o, d, (0, 0), 7.0 - c, 5, 15)
    if volume == "lamp":
        cone, shift = layer.cut_shape
        q = o - np.array([0.0, 0.0, CONE_Z]) - shift
        return _in_cube(o, d, 10.0) + revolved_path(q, d, cone)
    if volume == "orbcut":
        return _orb_less_half_space(o, d, 3.0 - c)
    if volume == "pie":
        return _pie_path(o, d, 10.0 - c)
    r1, r2 = _bore_radii(layer)
    return _in_cube(o, d, 10.0) - _in_box_and_cone(o, d, r1, r2)


def _pie_path(o: np.ndarray, d: np.ndarray, r: float) -> float:
    """Path of the ray o + t d (t > 0) in three quarters of the disk of radius r, |z| < 5 mm
    (all but x > 0, y < 0), and the plate |x|, |y| < 12 mm, -9 < z < -5 mm under it: the
    cylinder's roots and the planes cut the ray into pieces, each kept whose middle is in
    either."""
    a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
    disc = b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - r * r)
    ts = [0.0] + ([(-b + s * math.sqrt(disc)) / (2 * a) for s in (-1, 1)] if disc > 0 else [])
    planes = [(0, 0.0), (1, 0.0), (0, -12.0), (0, 12.0), (1, -12.0), (1, 12.0)]
    planes += [(2, -9.0), (2, -5.0), (2, 5.0)]
    ts += [(v - o[k]) / d[k] for k, v in planes if abs(d[k]) > 1e-15]
    ts = np.unique([t for t in ts if 0 <= t < 1e3])
    total = 0.0
    for a_, b_ in itertools.pairwise(ts):
        x, y, z = o + (a_ + b_) / 2 * d
        pie = math.hypot(x, y) < r and abs(z) < 5 and not (x > 0 and y < 0)
        plate = abs(x) < 12 and abs(y) < 12 and -9 < z < -5
        total += (b_ - a_) if pie or plate else 0.0
    return total


def _bore_radii(layer) -> tuple[float, float]:
    """Radii of the widened bore at z = -10 and 10 mm (the box's faces): the subtracted cone
    (r 4 mm at z = -20 mm, 8 mm at z = 20 mm) grown by the cut along its normal."""
    grow = layer.into_cut * math.hypot(4.0, 40.0) / 40.0
    return 5.0 + grow, 7.0 + grow


def _in_box_and_cone(o: np.ndarray, d: np.ndarray, r1: float, r2: float) -> float:
    """Path of the ray o + t d (t > 0) in the 20 mm cube and in the cone of radius r1 at
    z = -10 mm and r2 at z = 10 mm (about z): the roots of the cone's quadratic and the cube's
    planes cut the ray into pieces, each kept whose middle is in both."""
    b = (r2 - r1) / 20.0
    ra, rb = r1 + b * (o[2] + 10.0), b * d[2]  # r(t) = ra + rb t on the cone's line
    qa = d[0] ** 2 + d[1] ** 2 - rb**2
    qb = 2 * (o[0] * d[0] + o[1] * d[1]) - 2 * ra * rb
    qc = o[0] ** 2 + o[1] ** 2 - ra**2
    disc = qb * qb - 4 * qa * qc
    ts = [0.0] + ([(-qb + s * math.sqrt(disc)) / (2 * qa) for s in (-1, 1)] if disc > 0 else [])
    with np.errstate(divide="ignore"):
        ts += [float(t) for t in np.concatenate([(-10.0 - o) / d, (10.0 - o) / d])]
    ts = np.unique([t for t in ts if 0 <= t < 1e3])
    total = 0.0
    for a_, b_ in itertools.pairwise(ts):
        m = o + (a_ + b_) / 2 * d
        if (np.abs(m) < 10).all() and math.hypot(m[0], m[1]) < r1 + b * (m[2] + 10.0):
            total += b_ - a_
    return total


def _cut_volume(volume: str, layer) -> float:
    """The cut boolean's volume from its dimensions (mm3)."""
    c = layer.into_cut
    if volume == "stack":
        return math.pi * (100.0 * 10.0 + (7.0 - c) ** 2 * 10.0)
    if volume == "lamp":
        cone = layer.cut_shape[0]
        r1, r2, h = cone.rmax1, cone.rmax2, 2 * cone.dz
        return 8000.0 + math.pi * h / 3 * (r1 * r1 + r1 * r2 + r2 * r2)
    if volume == "pie":
        return 0.75 * math.pi * (10.0 - c) ** 2 * 10.0 + 24.0 * 24.0 * 4.0
    if volume == "orbcut":
        r = 3.0 - c
        h = r - ORB_CUT  # the cap beyond x = 1.5
        return 4 / 3 * math.pi * r**3 - math.pi * h * h * (3 * r - h) / 3
    r1, r2 = _bore_radii(layer)
    return 8000.0 - math.pi * 20.0 / 3 * (r1 * r1 + r1 * r2 + r2 * r2)


def _crossings(old, o: np.ndarray, d: np.ndarray) -> list[np.ndarray]:
    """Where the ray o + t d (0 < t < 40 mm, the target's frame) crosses the face of the old
    constituent ``old`` (a face clip): sign changes of its signed distance on a 10 um grid,
    each found by bisection."""

    def dist(t: np.ndarray) -> np.ndarray:
        return old.leaf.signed_distance(old.transform.inverse_apply(o + t[:, None] * d))

    t = np.arange(0.0, 40.0, 0.01)
    s = np.sign(dist(t))
    out = []
    for k in np.flatnonzero(s[1:] != s[:-1]):
        lo, hi = np.array([t[k]]), np.array([t[k + 1]])
        for _ in range(50):
            mid = (lo + hi) / 2
            if np.sign(dist(mid))[0] == s[k]:
                lo = mid
            else:
                hi = mid
        out.append(o + lo[0] * d)
    return out


def _rays(volume: str, target, layer, rng: np.random.Generator, n: int):
    """``n`` rays (the target's frame) from 0.3 mm outside kept cells of the old face, aimed in
    through the layer (down into the disk or the box from the post and the cone)."""
    lay = layer.ring_layout
    cells = layer.cells()
    turn = target.rotation.T @ layer.target.rotation  # the constituent's frame in the target's
    starts, ways = [], []
    while len(starts) < n:
        j, _i, _v, phi = cells[rng.integers(len(cells))]
        u = phi + rng.uniform(-0.3, 0.3) * lay.step[j]
        normal = lay.face.normal(u, lay.v[j])
        p = lay.face.point(u, lay.v[j]) + (layer.into_cut + 0.3) * normal
        start = target.to_local(layer.target.to_world(p[None]))[0]
        normal = turn @ normal
        if volume == "orbcut":
            aim = np.array([rng.uniform(-1.5, 1.0), *rng.uniform(-1.5, 1.5, 2)])
        else:
            aim = start - 6.0 * np.array([normal[0], normal[1], 0.0]) - [0.0, 0.0, DOWN[volume]]
        starts.append(start)
        ways.append((aim - start) / np.linalg.norm(aim - start))
    return np.array(starts), np.array(ways)


@pytest.mark.deep
@pytest.mark.parametrize("volume", list(CASES))
def test_geantino_paths_through_an_into_layer_on_a_curved_face(gdml, volume, tmp_path):
    """Geantinos from 0.3 mm outside the old face, in through the layer: Geant4's track length
    in the target (the boolean rebuilt with the thinner constituent) equals the path in the cut
    solid from its dimensions plus the path in the bent patch bodies near the crossing, to
    1e-9 mm; Geant4's volume of the rebuilt boolean (its own estimate for a boolean) is the cut
    solid's from its dimensions (deep: ~12-17 s each)."""
    data = _one(gdml, volume, output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    (layer,) = scene.layers
    target = scene.target(volume)
    n = 10
    local, ways = _rays(volume, target, layer, np.random.default_rng(13), n)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, target.to_world(local), ways @ target.rotation.T, tmp_path)
    got = np.asarray(r.scores["track_length"][volume])
    old = target.shape.face_clip(CASES[volume][0])
    crossed = 0
    for k in range(n):
        o, d = local[k], ways[k]
        near = []  # the bent patches near each crossing of the old face, each once
        for at in _crossings(old, o, d):
            at = layer.target.to_local(target.to_world(at[None]))[0]
            dphi = 4 * max(layer.patch_size) / abs(at[:2]).max()
            try:
                near.append(wall_patches_near(layer, target, at, dphi).reshape(-1, 9))
            except ValueError:  # no kept cell there (the orb's cut side)
                continue
        in_patches = 0.0
        if near:
            tri = np.unique(np.concatenate(near), axis=0).reshape(-1, 3, 3)
            in_patches = mesh_path(o, d, tri, edge=1e-12, merge=1e-10)
        crossed += in_patches > 0
        expected = _solid_path(volume, layer, o, d)
        assert expected > 0.1
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2
    (record,) = r.run["volumes"]
    g4_volume = record["volume_mm3"] - record["layer_volume_mm3"]
    assert g4_volume == pytest.approx(_cut_volume(volume, layer), rel=VOLUME_REL[volume])


@pytest.mark.deep
def test_into_curved_faces_of_booleans_pass_the_overlap_check(gdml, tmp_path):
    """`score4 geometry check` (Geant4's overlap check over the rebuilt booleans and the bent
    cells of all three layers, their tiling checked exactly) finds no overlaps (deep: ~10 s)."""
    data = config(gdml, {v: [face] for v, (face, _) in CASES.items()})
    path = tmp_path / "into_curved.yaml"
    path.write_text(yaml.safe_dump(data))
    assert_no_overlaps(path)


@pytest.mark.parametrize(
    ("volume", "faces", "message"),
    [
        (
            "pie",
            ["first.phi_start"],
            (
                "targets.0.rough.0: into: true on face first.phi_start of 'pie' (a G4UnionSolid) "
                "(face phi_start of a G4Tubs with a phi segment): the cut would move that plane "
                "off the axis"
            ),
        ),
        (
            "pie",
            ["first.outer", "first.phi_end"],
            "targets.0.rough.1: into: true on face first.phi_end of 'pie'",
        ),
        (
            "pie",
            ["first.outer", "second.+z"],
            (
                "targets.0.rough: into: true on faces second.+z and first.outer of 'pie': the "
                "part first of the union stands on face second.+z and grows down into its cut, "
                "and score4 cuts a face of such a part that meets its foot only on a G4Tubs, "
                "G4Cons or polycone with a full circle"
            ),
        ),
    ],
)
def test_into_where_a_boolean_still_refuses_it(gdml, volume, faces, message):
    """A tube's phi face (alone or with its wall), and the wall of a tube with a phi segment
    with the plate's top it stands on (the wall's cut and the tube's growth down into the
    plate's cut meet at its foot, which score4 cuts together on a full circle only,
    tests/test_boolean_into_joint.py): one line naming the faces and the rule, before anything
    is built."""
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, {volume: faces})))
    assert str(err.value).startswith(message)
    assert "\n" not in str(err.value)


@pytest.mark.deep
def test_into_curved_faces_of_booleans_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """All five layers in one world, written by `score4 geometry export`: Geant4 reads the file
    back, and the file pyg4ometry reads and writes again, with the same geantino paths
    (volumes and points, 1e-9 mm) as the world score4 builds; most rays cross a patch (deep:
    ~2 min at load 12)."""
    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    data = config(gdml, {v: [face] for v, (face, _) in CASES.items()})
    path = tmp_path / "into_curved.yaml"
    path.write_text(yaml.safe_dump(data))
    out = tmp_path / "into_curved.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    scene = build_scene(parse_config(data))
    rays = []
    for k, volume in enumerate(CASES):
        target = scene.target(volume)
        layer = scene.layer(volume, CASES[volume][0])
        local, ways = _rays(volume, target, layer, np.random.default_rng(20 + k), 3)
        world, turned = target.to_world(local), ways @ target.rotation.T
        rays += [(o.tolist(), d.tolist()) for o, d in zip(world, turned, strict=True)]
    ours, back, relay = three_paths(path, out, rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= 10
