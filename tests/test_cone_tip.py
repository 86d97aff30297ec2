"""A rough layer on a cone closing to a point (a drill tip; issue 24): its rings near the tip,
where a bent patch cannot follow the surface within the gap limit, stay flat
(``rough_shares``), the rest is rough; before, the whole face was refused as "curved too
tightly". A cylinder (every ring alike) and a cone too narrow everywhere are still refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_curved_rough import PYRAMIDS, cylinder_config, ray_path, write_cone

from score4.errors import ConfigError
from score4.inputs.config import parse_config
from score4.source.build import make_source
from score4.world.curved import gap_limit, measure_floor
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.geantinos import geantino_run

R2, HALF_Z = 1.0, 1.0  # the cone's radius at +z (0 at -z) and its half length, mm


@pytest.fixture(scope="module")
def tip(tmp_path_factory):
    return write_cone(tmp_path_factory.mktemp("tip") / "tip.gdml", r1=0.0, r2=R2, half_z=HALF_Z)


def test_rings_near_the_tip_stay_flat(tip):
    """Pyramids of 100 um on a cone from a point to 1 mm: the rings held keep the base within
    the gap limit (0.1 um; it was 0.69 um at the narrowest ring that held patches before), the
    next narrower ring would not (its floor's chords dip deeper than the limit allows), every
    ring wider holds patches, and the rough share is the held cells' area over the face's."""
    scene = build_scene(parse_config(cylinder_config(tip)))
    (layer,) = scene.layers
    assert isinstance(layer, CurvedRoughLayer)
    lay = layer.ring_layout
    limit = gap_limit(10e-3)
    assert layer.gap <= limit
    held = lay.count > 0
    first = int(np.flatnonzero(held)[0])
    assert first > 0
    assert held[first:].all()
    flat = layer._flat(0)
    heights = [measure_floor(lay, flat, layer.base_thickness, j) for j in range(len(lay.v))]
    highest = max(hi for _, hi in heights[first:])
    assert highest - heights[first - 1][0] > limit
    px, py = layer.patch_size
    share = lay.count.sum() * px * py / layer.face_area
    assert layer.rough_share == pytest.approx(share, rel=1e-12)
    assert 0.85 < layer.rough_share < 0.95
    assert layer.pieces is not None  # the envelope ends at the first held ring's cells
    ((_, dphi, v0, v1, _),) = layer.pieces
    assert dphi == pytest.approx(2 * np.pi)
    assert v1 == lay.face.extent[1][1]
    assert lay.v[first - 1] < v0 < lay.v[first] - py / 2  # (cells reach beyond the band)


@pytest.mark.parametrize(
    "faces", [pytest.param(["outer"], id="into-wall"), pytest.param(["outer", "+z"], id="joint")]
)
def test_cells_of_a_tip_cut_for_into_tile_the_envelope(tip, faces):
    """With ``into`` on the cone's wall (and on its wide end face, cut together with it) the
    narrow rings stay flat too, and every cell lies in the envelope's piece, which ends at the
    held rings' cells (:func:`score4.geometry.check.curved_cells_tile`, exact; the piece is
    taken again once the layer's top is padded to the old face: before, one ring's 9 cells
    lay outside it in the joint cut)."""
    from score4.geometry.check import curved_cells_tile

    data = cylinder_config(tip)
    data["targets"][0]["rough"] = [{"face": f, "surface": "p", "into": True} for f in faces]
    wall = build_scene(parse_config(data)).layers[0]
    assert isinstance(wall, CurvedRoughLayer)
    assert wall.ring_layout.least > 0
    assert wall.pieces is not None
    checked, problems = curved_cells_tile(wall)
    assert checked == wall.ring_layout.count.sum()
    assert not problems


def test_a_cone_narrow_everywhere_is_still_refused(tmp_path):
    """A cone from a point to 0.1 mm: no ring is wide enough, one line with the radius it
    needs."""
    gdml = write_cone(tmp_path / "narrow.gdml", r1=0.0, r2=0.1, half_z=HALF_Z)
    with pytest.raises(ConfigError, match=r"curved too tightly .* radius >= [\d.]+ mm"):
        build_scene(parse_config(cylinder_config(gdml)))


@pytest.mark.parametrize(
    "into",
    [pytest.param(False, id="outside"), pytest.param(True, id="into", marks=pytest.mark.deep)],
)
def test_geantino_paths_through_a_drill_tip(tip, tmp_path, into):
    """Horizontal geantinos through the cone's rough part and through its flat tip: Geant4's
    track length in the cone (its patches count) equals the ray trace of the analytic cone plus
    the bent patch mesh, to 1e-9 mm; with ``into`` (deep) the same through the cone cut by the
    layer's thickness along its normal (its tip moved up the axis)."""
    data = cylinder_config(tip, output={"track_length": True})
    data["targets"][0]["rough"][0]["into"] = into
    config = parse_config(data)
    scene = build_scene(config)
    (layer,) = scene.layers
    assert (layer.ring_layout.count == 0).any()
    assert layer.pieces is not None
    rng = np.random.default_rng(11)
    n = 24
    primaries = make_source(config, scene).primaries(np.random.default_rng(1), 0, n)
    z = np.concatenate([rng.uniform(0.2, 0.8, n - 6), rng.uniform(-0.8, -0.2, 6)])
    r = R2 / 2 * (1 + z / HALF_Z)  # the cone's radius at z
    phi = rng.uniform(0, 2 * np.pi, n)
    start = np.column_stack([(r + 0.1) * np.cos(phi), (r + 0.1) * np.sin(phi), z])
    aim = np.column_stack([rng.uniform(-0.1, 0.1, n), rng.uniform(-0.1, 0.1, n), z])
    direction = aim - start
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    res = geantino_run(data, primaries, start, direction, tmp_path)
    slope = R2 / (2 * HALF_Z)
    r0 = R2 / 2 - (layer.into_cut * math.sqrt(1 + slope**2) if into else 0.0)
    expected = ray_path(start, direction, layer, r0, HALF_Z, slope=slope)
    assert (expected > 0).all()
    np.testing.assert_allclose(res.scores["track_length"]["cyl"], expected, rtol=0, atol=1e-9)


@pytest.mark.deep
def test_geant4_finds_no_overlap_on_a_drill_tip(tip, tmp_path):
    """Geant4's own overlap check over the rings of the cone's rough part."""
    import yaml

    from helpers.g4_geometry_check import assert_no_overlaps

    (tmp_path / "tip.yaml").write_text(yaml.safe_dump(cylinder_config(tip)))
    assert_no_overlaps(tmp_path / "tip.yaml")


TIP = 1.5 / math.tan(math.radians(59))  # a 118 degree drill's tip on a 3 mm hole, mm


def drilled(s, reg):
    """A copper block (10 mm) less a blind hole drilled from +z: r 1.5 mm down to z = -4 mm,
    then the drill's cone to a point (a G4GenericPolycone: seg_0 the tip, seg_1 the wall)."""
    r, z = [0.0, 1.5, 1.5, 0.0], [-4 - TIP, -4.0, 11.0, 11.0]
    return {"drilled": (s.GenericPolycone("drill_h", 0, 2 * math.pi, r, z, reg), (0, 0, 0), 0.0)}


@pytest.mark.deep
def test_geantino_paths_through_a_drilled_holes_tip_and_wall(tmp_path):
    """Rough layers on the drill tip and the wall of a blind hole (a boolean): the tip's rings
    near its point stay flat, the rest of both faces is rough; geantinos from the hole's axis
    aimed at the tip and at the wall just above it cross the patches and the copper: Geant4's
    track length in the block equals the path in the block less the hole (its signed distance,
    bisected) plus the path in the patch bodies, 1e-9 mm, and its volume to 2e-4."""
    from helpers.boolean_worlds import write_box_holes
    from helpers.geantinos import assert_box_paths
    from helpers.ray_trace import patches_path, polycone_path

    gdml = write_box_holes(tmp_path / "drilled.gdml", drilled, half=5.0)
    faces = ["second.seg_0", "second.seg_1"]
    data = {
        "physics": "lite",
        "world": {"gdml": str(gdml)},
        "surfaces": {"p": PYRAMIDS},
        "targets": [{"volume": "drilled", "rough": [{"face": f, "surface": "p"} for f in faces]}],
        "source": {
            "particle": "geantino",
            "energy": "1 MeV",
            "surface": {"volume": "drilled", "face": faces},
        },
        "run": {"events": 10, "seed": 3},
        "output": {"track_length": True},
    }
    scene = build_scene(parse_config(data))
    tip, wall = scene.layers_of("drilled")
    assert isinstance(tip, CurvedRoughLayer)
    assert tip.pieces is not None
    assert 0.8 < tip.rough_share < 0.95
    assert (tip.ring_layout.count == 0).any()
    rng = np.random.default_rng(5)
    n = 16
    rho = np.concatenate([rng.uniform(0.3, 1.45, n - 4), np.full(4, 1.5)])
    z = np.concatenate([-4 - (1.5 - rho[: n - 4]) * TIP / 1.5, rng.uniform(-3.9, -3.0, 4)])
    phi = rng.uniform(0, 2 * np.pi, n)
    aim = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    start = np.tile([0.0, 0.0, -2.0], (n, 1))
    d = aim - start
    d /= np.linalg.norm(d, axis=1)[:, None]
    target = scene.target("drilled")
    hole = math.pi * 1.5**2 * (9.0 + TIP / 3)
    crossed = assert_box_paths(
        data,
        scene,
        start,
        d,
        ["drilled"] * n,
        lambda v, o, dd: polycone_path(o, dd, target.shape),
        lambda v: 10.0**3 - hole,
        tmp_path,
    )
    assert crossed >= 10
    assert sum(patches_path(o, dd, wall) > 0 for o, dd in zip(start, d, strict=True)) >= 2
