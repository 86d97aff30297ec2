"""``into: true`` on a flat face of a union's constituent that another part of the union stands
on (score4.world.boolean_modes.standing_cuts): the cut takes the slab behind the face, and the
part standing on it grows down by the same depth, so the slab under it stays in the volume (no
vacuum gap under the post); a part that covers the face some other way is refused in one line.
Against paths and volumes written here from the solids' dimensions."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.source.build import make_source
from score4.world.resolve import build_scene

from helpers.boolean_worlds import copper_world_text
from helpers.g4_geometry_check import assert_no_overlaps
from helpers.geantinos import geantino_config, geantino_run, rough_targets
from helpers.ray_trace import flat_patches_path

# one worker per module: its world is written and its boolean face areas estimated once
pytestmark = pytest.mark.xdist_group("into-covered")

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
#: where the solids stand
AT = {
    "stack": (0.0, -40.0, 0.0),
    "wide": (0.0, 40.0, 0.0),
    "holed": (-40.0, 0.0, 0.0),
}


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """``stack``: a disk (r 10 mm, 10 mm high) with a post (r 7 mm, 10 mm high) on it;
    ``wide``: the disk with the post moved 6 mm off its axis (it overhangs the disk's
    rim); ``holed``: the stack with a hole (r 2 mm) through the disk under the post. Written as
    GDML text."""
    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    solids = f"""
<box name="world_s" x="200" y="200" z="200" lunit="mm"/>
<tube name="stack_a" rmin="0" rmax="10" z="10" {full}/>
<tube name="stack_b" rmin="0" rmax="7" z="10" {full}/>
<union name="stack_s"><first ref="stack_a"/><second ref="stack_b"/>
  <position name="stack_p" x="0" y="0" z="10" unit="mm"/></union>
<tube name="wide_a" rmin="0" rmax="10" z="10" {full}/>
<tube name="wide_b" rmin="0" rmax="7" z="10" {full}/>
<union name="wide_s"><first ref="wide_a"/><second ref="wide_b"/>
  <position name="wide_p" x="6" y="0" z="10" unit="mm"/></union>
<tube name="holed_a" rmin="0" rmax="10" z="10" {full}/>
<tube name="holed_h" rmin="0" rmax="2" z="20" {full}/>
<subtraction name="holed_d"><first ref="holed_a"/><second ref="holed_h"/></subtraction>
<tube name="holed_b" rmin="0" rmax="7" z="10" {full}/>
<union name="holed_s"><first ref="holed_d"/><second ref="holed_b"/>
  <position name="holed_p" x="0" y="0" z="10" unit="mm"/></union>"""
    text = copper_world_text(solids, AT)
    path = tmp_path_factory.mktemp("into_covered") / "into_covered.gdml"
    path.write_text(text)
    return path


def config(gdml: Path, volume: str, face: str, **extra) -> dict:
    targets = rough_targets({volume: [face]}, into=True)
    return geantino_config(gdml, {"p": PYRAMIDS}, targets, (volume, face), **extra)


def test_into_under_a_post_keeps_the_slab_under_it(gdml):
    """into: true on the disk's top (first.+z), where the post stands on its middle: the point
    half a layer under the post's foot stays in the volume (on main before the fix it was cut
    away: the post floated over a vacuum gap as thick as the layer), the slab in the ring
    around the post is cut (in the volume only inside a patch), the layer's kept cells lie
    outside the post (their whole square), and the source stays in the volume."""
    scene = build_scene(parse_config(config(gdml, "stack", "first.+z")))
    (layer,) = scene.layers
    target = scene.target("stack")
    t = layer.thickness
    under = target.to_world(np.array([[0.0, 0.0, 5.0 - t / 2], [6.9, 0.0, 5.0 - t / 2]]))
    assert scene.inside_target("stack", under).all()
    assert scene.inside_target("stack", target.to_world(np.array([[0.0, 0.0, 5.0 + t]]))).all()
    ring = target.to_world(np.array([[8.6, 0.0, 5.0 - t / 2], [0.0, -8.6, 5.0 - t / 2]]))
    np.testing.assert_array_equal(scene.inside_target("stack", ring), layer.contains(ring))
    assert not scene.inside_target("stack", target.to_world(np.array([[8.6, 0.0, 5.0 + 1e-6]])))[0]
    centres = layer.cell_centres()[layer.mask]
    px, py = layer.patch_size
    flat = np.column_stack([centres, np.zeros(len(centres))])
    local = target.to_local(layer.frame.to_world(flat))
    assert local[:, 2] == pytest.approx(5.0 - t, abs=1e-12)
    axis = layer.frame.to_local(target.to_world(np.array([[0.0, 0.0, 5.0 - t]])))[0, :2]
    gap = np.maximum(np.abs(centres - axis) - np.array([px, py]) / 2, 0.0)
    assert np.hypot(gap[:, 0], gap[:, 1]).min() >= 7.0 - 1e-9  # each cell's nearest point
    assert len(centres) > 100
    cfg = parse_config(config(gdml, "stack", "first.+z"))
    drawn = make_source(cfg, scene).primaries(np.random.default_rng(3), 0, 300).position
    assert scene.inside_target("stack", drawn).all()


@pytest.mark.parametrize(
    ("volume", "face", "part"),
    [
        ("wide", "first.+z", "the G4Tubs second"),
        ("holed", "first.first.+z", "the G4Tubs second"),
    ],
)
def test_into_under_a_part_that_cannot_grow_down_says_why_not(gdml, volume, face, part):
    """A post overhanging the disk's rim, and a post over a hole through the disk (grown down,
    it would fill the hole's top): growing them down would not give the cut solid exactly, so
    into: true is refused in one line naming the face, the part and the rule (a cone grows as
    the prism of its foot: tests/test_boolean_into_joint.py)."""
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, volume, face)))
    msg = str(err.value)
    assert msg.startswith(f"targets.0.rough.0: into: true on face {face} of {volume!r} (a ")
    assert f"another part of the union ({part}) stands on this face" in msg
    assert "\n" not in msg


def _stack_path(o: np.ndarray, d: np.ndarray, t: float) -> float:
    """Path of the ray o + s d (s > 0) in the disk r < 10, -5 < z < 5 - t and the post r < 7,
    5 - t < z < 15 (the post grown down by t): pieces between the roots of both cylinders and
    the planes, each kept whose middle is in either."""
    ts = [0.0]
    a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
    for r in (10.0, 7.0):
        disc = b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - r * r)
        if a > 0 and disc > 0:
            ts += [(-b + s * math.sqrt(disc)) / (2 * a) for s in (-1, 1)]
    if abs(d[2]) > 1e-15:
        ts += [(z - o[2]) / d[2] for z in (-5.0, 5.0 - t, 15.0)]
    ts = sorted(s for s in ts if 0 <= s < 1e3)
    total = 0.0
    for s0, s1 in itertools.pairwise(ts):
        x, y, z = o + (s0 + s1) / 2 * d
        r = math.hypot(x, y)
        if (r < 10 and -5 < z < 5 - t) or (r < 7 and 5 - t < z < 15):
            total += s1 - s0
    return total


@pytest.mark.deep
def test_geantino_paths_under_a_post_with_into(gdml, tmp_path):
    """Geantinos from above the ring around the post, aimed in under the post (half of them
    through the slab under its foot, where the post grew): Geant4's track length in the target
    (the disk cut by the layer, the post grown down by it) equals the path in that solid from
    its dimensions plus the path in the patch bodies near the ray, to 1e-9 mm (on main before
    the fix the first ray was 5.7 mm short: the gap); the union's volume is the two tubes'
    (deep: ~10 s)."""
    data = config(gdml, "stack", "first.+z", output={"track_length": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    (layer,) = scene.layers
    target = scene.target("stack")
    t = layer.thickness
    rng = np.random.default_rng(7)
    n = 10
    phi = rng.uniform(0, 2 * np.pi, n)
    r = rng.uniform(7.6, 9.6, n)
    local = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.full(n, 5.01)])
    aim = np.column_stack([rng.uniform(-3, 3, (n, 2)), rng.uniform(-4, 4.9, n)])
    aim[::2, 2] = 5.0 - t / 2  # half of them run on through the slab under the post
    ways = (aim - local) / np.linalg.norm(aim - local, axis=1, keepdims=True)
    starts, directions = target.to_world(local), ways @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r_ = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(r_.scores["track_length"]["stack"])
    crossed = 0
    for k in range(n):
        o, d = starts[k], directions[k]
        expected = _stack_path(local[k], ways[k], t)
        in_patches = flat_patches_path(layer, o, d, samples=400)
        crossed += in_patches > 0
        assert expected > 1.0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2
    (record,) = r_.run["volumes"]
    g4_volume = record["volume_mm3"] - record["layer_volume_mm3"]
    exact = math.pi * (100.0 * (10.0 - t) + 49.0 * (10.0 + t))
    assert g4_volume == pytest.approx(exact, rel=1e-12)


@pytest.mark.deep
def test_into_under_a_post_passes_the_overlap_check(gdml, tmp_path):
    """`score4 geometry check` (Geant4's overlap check over the rebuilt union and the layer's
    cells) finds no overlaps: the grown post and the layer's envelope (the prism of its kept
    cells) do not meet (deep: ~5 s)."""
    path = tmp_path / "into_covered.yaml"
    path.write_text(yaml.safe_dump(config(gdml, "stack", "first.+z")))
    assert_no_overlaps(path)
