"""``into: true`` on the side of a box post standing on a disk (a G4UnionSolid;
score4.world.boolean_modes.standing_cuts, _beside_slab): the disk touches the side's slab only
along the post's foot, beside it, and meets no inner point of it, so the post is cut behind
its side alone (before, any part whose box touched the slab was refused). A disk reaching a
micrometre up into the slab, or a post's side cut together with the disk's top it grows down
into, stay refused in one line. Geantino paths against the cut solid from its dimensions plus
the patch bodies (1e-9 mm), Geant4's volume, Geant4's overlap check (deep)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_boolean_faces import _box_path, _tube_path

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.shapes import BooleanShape, G4Box, G4Tubs, Transform
from score4.shapes.base import INSIDE, OUTSIDE
from score4.world.boolean_modes import standing_cuts
from score4.world.resolve import build_scene

from helpers.boolean_worlds import copper_world_text
from helpers.geantinos import geantino_config, rough_targets

pytestmark = pytest.mark.xdist_group("box-post-side")

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
AT = (0.0, 0.0, 0.0)
DISK_R, DISK_H = 10.0, 5.0  # the disk: r 10 mm, z -5 .. 5
POST = 3.0  # the post: x, y -3 .. 3, z 5 .. 15


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    solids = f"""
<box name="world_s" x="100" y="100" z="100" lunit="mm"/>
<tube name="block_a" rmin="0" rmax="10" z="10" {full}/>
<box name="block_b" x="6" y="6" z="10" lunit="mm"/>
<union name="block_s"><first ref="block_a"/><second ref="block_b"/>
  <position name="block_p" x="0" y="0" z="10" unit="mm"/></union>"""
    path = tmp_path_factory.mktemp("box_post") / "box_post.gdml"
    path.write_text(copper_world_text(solids, {"block": AT}))
    return path


def config(gdml: Path, faces: list[str]) -> dict:
    return geantino_config(
        gdml,
        {"p": PYRAMIDS},
        rough_targets({"block": faces}, into=True),
        ("block", faces[0]),
        output={"track_length": True},
    )


def test_the_disk_beside_the_side_slab_is_left_as_it_is():
    """standing_cuts on the post's +x side: the disk touches the slab along the foot only (no
    growth needed, no refusal); a disk 1 um higher reaches into the slab and is refused as
    before; a second box beside the post, touching the slab's edge, is left as it is."""
    post = Transform(np.eye(3), [0.0, 0.0, 10.0])
    shape = BooleanShape("union", G4Tubs(0.0, DISK_R, DISK_H), G4Box(POST, POST, 5.0), post)
    assert standing_cuts(shape, "second.+x", 0.02, "into") == {}
    higher = BooleanShape("union", G4Tubs(0.0, DISK_R, DISK_H + 1e-3), G4Box(POST, POST, 5.0), post)
    with pytest.raises(ConfigError) as err:
        standing_cuts(higher, "second.+x", 0.02, "into")
    assert str(err.value).startswith(
        "into: another part of the union (the G4Tubs first) stands on this face"
    )
    assert "\n" not in str(err.value)
    beside = BooleanShape(
        "union", G4Box(1.0, 1.0, 5.0), G4Box(POST, POST, 5.0), Transform(np.eye(3), [2.0, 4.0, 0])
    )
    assert standing_cuts(beside, "second.+x", 0.02, "into") == {}


def rays(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rays (the block's frame, the world's) from beyond the post's +x side in through it, half
    within 0.4 mm of its foot, some on into the disk."""
    z = np.where(np.arange(n) % 2 == 0, rng.uniform(5.0, 5.4, n), rng.uniform(5.4, 14.6, n))
    start = np.column_stack([np.full(n, 4.0), rng.uniform(-2.5, 2.5, n), z])
    aim = np.column_stack([np.full(n, -4.0), rng.uniform(-2.5, 2.5, n), z - rng.uniform(0, 1, n)])
    d = aim - start
    return start, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_the_post_is_cut_behind_its_side_alone(gdml):
    """The side's layer keeps every cell; the boolean it lies on is the disk with the post cut
    behind its +x side by the layer's thickness (the disk as it was)."""
    scene = build_scene(parse_config(config(gdml, ["second.+x"])))
    (layer,) = scene.layers_of("block")
    assert layer.mask is None or layer.mask.all()
    on = layer.on_boolean
    inside = on.shape.inside  # points just inside and outside the cut side and the disk
    t = layer.thickness
    q = np.array(
        [[POST - t - 1e-6, 0.0, 10.0], [POST - t + 1e-6, 0.0, 10.0], [POST - 1e-6, 0.0, 5.0 + 1e-6],
         [POST - 1e-6, 0.0, 5.0 - 1e-6], [DISK_R - 1e-6, 0.0, 0.0]]
    )  # fmt: skip
    assert (inside(q) == np.array([INSIDE, OUTSIDE, OUTSIDE, INSIDE, INSIDE])).all()


@pytest.mark.deep  # ~5 s
def test_geantino_paths_through_a_box_posts_rough_side(gdml, tmp_path):
    """Geantinos from beyond the post's +x side in through it, half near its foot: Geant4's
    track length in the union equals the path in the disk plus the path in the post cut behind
    its side by the layer's thickness, plus the path in the patch bodies, to 1e-9 mm; every cell
    of the side keeps its patch; Geant4's volume of the union less its layer is the cut
    solid's."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run
    from helpers.ray_trace import patches_path

    data = config(gdml, ["second.+x"])
    scene = build_scene(parse_config(data))
    (layer,) = scene.layers_of("block")
    assert layer.mask is None or layer.mask.all()
    t = layer.thickness
    n = 12
    start, d = rays(n, np.random.default_rng(3))
    primaries = make_source(parse_config(data), scene).primaries(np.random.default_rng(1), 0, n)
    got = geantino_run(data, primaries, start, d, tmp_path)
    length = np.asarray(got.scores["track_length"]["block"])
    crossed = 0
    for k in range(n):
        in_patches = patches_path(start[k], d[k], layer, 30.0)
        crossed += in_patches > 0
        a, b = _box_path(start[k], d[k], (-POST, -POST, DISK_H), (POST - t, POST, 15.0))
        disk = _tube_path(start[k], d[k], (0.0, 0.0), DISK_R, -DISK_H, DISK_H)
        assert length[k] == pytest.approx(b - a + disk + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2
    (record,) = got.run["volumes"]
    cut = np.pi * DISK_R**2 * 2 * DISK_H + (2 * POST - t) * 2 * POST * 10.0
    assert record["volume_mm3"] - record["layer_volume_mm3"] == pytest.approx(cut, rel=2e-4)


def test_a_post_side_with_the_disk_top_under_it_is_refused(gdml):
    """The post's side and the disk's top, both into: the post grows down into the disk's cut
    and its side's cut would leave a vacuum notch along the foot: one line naming both faces and
    why."""
    with pytest.raises(ConfigError) as err:
        build_scene(parse_config(config(gdml, ["first.+z", "second.+x"])))
    line = str(err.value)
    assert "\n" not in line
    assert line.startswith(
        "targets.0.rough: into: true on faces first.+z and second.+x of 'block': the box second "
        "of the union stands on face first.+z and grows down into its cut (its face -z), and its "
        "side +x meets that foot"
    )


@pytest.mark.deep
def test_a_box_posts_rough_side_passes_the_overlap_check(gdml, tmp_path):
    """Geant4's overlap check (``score4 geometry check``, in its own process) finds no overlap
    between the side's layer, the cut post and the disk."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    path = tmp_path / "post.yaml"
    path.write_text(yaml.safe_dump(config(gdml, ["second.+x"])))
    assert_no_overlaps(path)


@pytest.mark.deep
def test_a_box_posts_rough_side_exports_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The side's layer in a world written by `score4 geometry export`: Geant4 reads the file
    back, and the file pyg4ometry reads and writes again, with the same geantino paths (volumes
    and points, 1e-9 mm) as the world score4 builds (the cut post in the union)."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    path = tmp_path / "post.yaml"
    path.write_text(yaml.safe_dump(config(gdml, ["second.+x"])))
    out = tmp_path / "post.gdml"
    assert main(["geometry", "export", str(path), "--gdml", str(out)]) == 0
    start, d = rays(12, np.random.default_rng(41))
    out_rays = [(o.tolist(), w.tolist()) for o, w in zip(start, d, strict=True)]
    ours, back, relay = three_paths(path, out, out_rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("_rough" in (v or "") for v, _ in p) for p in ours) >= len(out_rays) // 2
