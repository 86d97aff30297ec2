"""Envelope pieces of sphere faces a boolean's other parts cut (issue 24), and the end runs of a
cylinder wall whose end rings hold no cells:

* an orb less a square hole along z, with a sister post standing through the hole: the sphere
  face's envelope is G4Sphere segments over its kept cells only, clear of the post (the whole
  zone met it and was refused);
* a half sphere on a plate with a post through both (a union of unions): the envelope stops
  at the last ring the post leaves whole (the whole zone ran into the post);
* a rod whose lower end stands in a box: its wall's one piece starts at the first kept ring,
  not at the rod's end inside the box (it reached into the box and was refused);
* ((rod | box) - half ring), a groove cut beside the rod's wall: the piece passing through it
  is no longer searched there for the solid's other parts (it was refused after 2e6 cells).

Geant4's overlap check, geantino paths to 1e-9 mm against the solids' signed distances plus
the patch bodies, and the export read back with the same paths run under ``deep``, as do the
cases whose boolean face areas cost seconds with a cold cache (the dome, the groove)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.geometry.check import curved_cells_tile
from score4.inputs.config import parse_config
from score4.shapes import BooleanShape, G4Box, G4Tubs, PlacedShape, Transform
from score4.shapes.base import INSIDE
from score4.shapes.faces import SphereFace
from score4.source.build import make_source
from score4.world import boolean_layers
from score4.world.boolean_layers import _pieces_in_solid
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers.export_paths import assert_same_paths, three_paths
from helpers.g4_geometry_check import assert_no_overlaps
from helpers.geantinos import geantino_config, geantino_run
from helpers.ray_trace import patches_path, polycone_path
from helpers.sphere_worlds import DOME_POST, DOME_R, HOLE, ORB_R, write_sphere_world

# one worker per module: its boolean solids' face areas are estimated once (cold: a few s)
pytestmark = pytest.mark.xdist_group("sphere-pieces")

#: 0.2 mm patches of 10 x 10 pyramids 10 um high (the orb, r 3 mm)
SMALL = {"kind": "spikes", "nx": 10, "ny": 10, "width": "20 um", "height": "10 um"}
#: 0.4 mm patches of 5 x 5 pyramids 20 um high (the dome, r 10 mm; the rod, r 5 mm)
FINE = {"kind": "spikes", "nx": 5, "ny": 5, "width": "80 um", "height": "20 um"}
#: 0.1 mm patches of 10 um pyramids (the groove's rod, r 5 mm: an 11 um layer)
TINY = {"kind": "spikes", "nx": 10, "ny": 10, "width": "10 um", "height": "10 um"}
#: volume -> (face, surface)
CASES = {
    "orbhole": ("first.outer", SMALL),
    "dome": ("first.first.outer", FINE),
    "peg": ("second.outer", FINE),
}
#: the rod's wall of ``groove``, (rod | box) - half ring
GROOVE = ("first.first.outer", TINY)
ALL = {**CASES, "groove": GROOVE}


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    return write_sphere_world(tmp_path_factory.mktemp("spheres") / "spheres.gdml")


def config(gdml: Path, volumes: list[str], **extra) -> dict:
    surfaces = {v: ALL[v][1] for v in volumes}
    targets = [{"volume": v, "rough": [{"face": ALL[v][0], "surface": v}]} for v in volumes]
    return geantino_config(gdml, surfaces, targets, (volumes[0], ALL[volumes[0]][0]), **extra)


def _layer(gdml: Path, volume: str) -> CurvedRoughLayer:
    scene = build_scene(parse_config(config(gdml, [volume])))
    layer = scene.layer(volume, ALL[volume][0])
    assert isinstance(layer, CurvedRoughLayer)
    return layer


def _ring_ranges(layer: CurvedRoughLayer, j: int) -> list[tuple[float, float]]:
    """Azimuth ranges (absolute) of the kept cells of ring ``j``, one per cell, and the flat
    rest the ring leaves at the face's phi edges (the seam of a full circle) beside a kept
    first or last cell (as on a cylinder's or cone's envelope)."""
    lay = layer.ring_layout
    n = int(lay.count[j])
    phi, step = lay.cell_phi(j), float(lay.step[j])
    keep = layer.cell_variants[j, :n] >= 0
    out = [(p - step / 2, p + step / 2) for p in phi[keep]]
    f = lay.face
    if keep[0]:
        out.append((f.phi0, phi[0] - step / 2))
    if keep[-1]:
        out.append((phi[-1] + step / 2, f.phi0 + f.dphi))
    return out


def _covered(ranges: list[tuple[float, float]], lo: float, hi: float, slack: float) -> bool:
    """[lo, hi] (an azimuth range, mod 2 pi) lies in the union of ``ranges`` (within
    ``slack``)."""
    shifted = []
    for a, b in ranges:  # each range once from lo - slack on, and once a turn before
        s = 2 * np.pi * np.floor((a - lo + slack) / (2 * np.pi))
        shifted += [(a - s, b - s), (a - s - 2 * np.pi, b - s - 2 * np.pi)]
    at = lo
    for a, b in sorted(shifted):
        if a <= at + slack and b > at:
            at = b
    return at >= hi - slack


def test_a_sphere_less_a_hole_keeps_clear_of_the_post_standing_in_it(gdml, monkeypatch):
    """The orb's face (r 3 mm, 0.2 mm patches) less a 3 mm square hole along z: the rings the
    hole's corners cut take one piece per run of kept cells, the whole rings between them one
    piece each way; every piece is a G4Sphere segment over its rings' bands, no piece holds a
    cell that is not kept (its azimuths lie in each of its rings' kept cells, or the flat rest
    at the seam beside them), every kept cell
    lies in one (exact tiling), no point of the envelope is over the hole, and the layer passes
    the clearance check against the post (2.8 mm square) standing in the hole. With the whole
    zone as envelope (as before), the layer is refused naming the post."""
    layer = _layer(gdml, "orbhole")
    lay = layer.ring_layout
    assert layer.pieces is not None
    views = layer.envelope_views()
    assert len(views) == len(layer.pieces) > 4
    kept = layer.cell_variants >= 0
    partial = [j for j in range(len(lay.v)) if kept[j].any() and not kept[j, : lay.count[j]].all()]
    assert len(partial) >= 4  # rings the hole's corners cut
    half = 0.5 * (lay.patch_size[1] + lay.row_gap)
    for (phi0, dphi, v0, v1, *_), view in zip(layer.pieces, views, strict=True):
        face = view.ring_layout.face
        assert isinstance(face, SphereFace)
        assert face.theta[1] - face.theta[0] == pytest.approx((v1 - v0) / ORB_R, abs=1e-12)
        rings = [j for j in range(len(lay.v)) if v0 < lay.v[j] < v1]
        assert rings
        assert v0 == pytest.approx(lay.v[rings[0]] - half, abs=1e-12)
        assert v1 == pytest.approx(lay.v[rings[-1]] + half, abs=1e-12)
        for j in rings:  # the piece's azimuths are kept cells of each of its rings
            if dphi < 2 * np.pi - 1e-9:
                assert _covered(_ring_ranges(layer, j), phi0, phi0 + dphi, 1e-12), (j, phi0)
            else:
                assert kept[j, : lay.count[j]].all()
    assert not curved_cells_tile(layer)[1]
    shell = layer.target.to_local(layer.shell_points(n_v=5))
    over_hole = (np.abs(shell[:, 0]) < HOLE) & (np.abs(shell[:, 1]) < HOLE)
    assert not over_hole.any()
    phi0, dphi, v0, v1, *rest = layer.pieces[0]
    layer.pieces[0] = (phi0, dphi, v0 + 1e-6, v1, *rest)  # a ring's cells cut short by 1 nm
    assert any("outside the pieces" in p for p in curved_cells_tile(layer)[1])
    monkeypatch.setattr(boolean_layers, "envelope_pieces", lambda layer: None)
    with pytest.raises(ConfigError) as err:
        _layer(gdml, "orbhole")
    assert "runs into sister volume 'orbpost'" in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.deep
def test_a_dome_with_a_post_through_it_stops_at_the_post(gdml, monkeypatch):
    """The half sphere's face (r 10 mm) with a post (r 5 mm) through its top: the rings the
    post covers keep no cell, and the envelope is one G4Sphere zone over the full circle from
    the band of the first ring (at the plate) to that of the last ring clear of the post; no
    point of it is inside the solid. With the whole zone (as before) it runs into the post and
    is refused in one line (deep: ~5 s CPU with a cold cache, the union's face areas)."""
    layer = _layer(gdml, "dome")
    lay = layer.ring_layout
    assert layer.pieces is not None
    ((_phi0, dphi, v0, v1, *_),) = layer.pieces
    assert dphi == pytest.approx(2 * np.pi, abs=1e-12)
    kept = np.flatnonzero((layer.cell_variants >= 0).any(axis=1))
    half = 0.5 * (lay.patch_size[1] + lay.row_gap)
    assert (v0, v1) == (lay.v[kept[0]] - half, lay.v[kept[-1]] + half)
    face = layer.envelope_views()[0].ring_layout.face
    assert isinstance(face, SphereFace)
    # the post's wall (r 5 mm) meets the dome (r 10 mm) at 30 degrees from the pole
    assert face.theta[0] > np.arcsin(DOME_POST / DOME_R)
    assert face.theta[0] - np.arcsin(DOME_POST / DOME_R) < 2 * lay.patch_size[1] / DOME_R
    on = layer.on_boolean
    codes = on.shape.inside(on.transform.inverse_apply(layer.shell_points(n_v=41)))
    assert not (codes == INSIDE).any()
    assert not curved_cells_tile(layer)[1]
    monkeypatch.setattr(boolean_layers, "envelope_pieces", lambda layer: None)
    with pytest.raises(ConfigError) as err:
        _layer(gdml, "dome")
    assert "runs into the solid itself" in str(err.value)
    assert "\n" not in str(err.value)


def test_a_rods_wall_starts_at_its_first_kept_ring(gdml):
    """The rod (r 5 mm, z -5 to 15 mm about the box's centre) stands with its lower 15 mm in
    the box (20 mm): its wall's envelope is one G4Tubs from the band of the first ring above
    the box's +z face to the rod's top (before, it reached the rod's lower end, inside the box,
    and the layer was refused)."""
    layer = _layer(gdml, "peg")
    lay = layer.ring_layout
    assert layer.pieces is not None
    ((phi0, dphi, v0, v1, *rest),) = layer.pieces
    (_, _), (fv0, fv1) = lay.face.extent
    kept = np.flatnonzero((layer.cell_variants >= 0).any(axis=1))
    assert kept[-1] == len(lay.v) - 1
    assert v1 == fv1
    assert v0 == float(lay.v[kept[0]]) - 0.5 * (lay.patch_size[1] + lay.row_gap)
    assert 5.0 <= v0 < 5.0 + lay.patch_size[1]  # the box's face, in the rod's frame
    assert not curved_cells_tile(layer)[1]
    assert _pieces_in_solid(layer, layer.on_boolean.clip, layer.on_boolean) is None
    layer.pieces = [(phi0, dphi, fv0, v1, *rest)]  # to the rod's end, as before
    assert _pieces_in_solid(layer, layer.on_boolean.clip, layer.on_boolean) is not None


def test_the_parts_searched_for_a_piece_are_the_unions_other_parts():
    """Each clip from outside of a face of a nested boolean is told apart by the operation
    that made it, in face_clip's order: in ((rod | box) - ring) the rod's wall is cut by the box
    (a union's other part: searched) and the ring (subtracted: not searched); in
    ((rod - ring) | box) the same two in the other order; in (rod & box) the box is a clip from
    inside; a placed constituent is looked through."""
    rod, box = G4Tubs(0.0, 5.0, 20.0), G4Box(10.0, 10.0, 10.0)
    ring = G4Tubs(5.0, 8.0, 4.0, 0.0, np.pi)
    up = Transform(np.eye(3), np.array([0.0, 0.0, 12.0]))
    cases = [
        (
            BooleanShape("subtraction", BooleanShape("union", rod, box), ring, up),
            "first.first.outer",
            ["union", "subtraction"],
        ),
        (
            BooleanShape("union", BooleanShape("subtraction", rod, ring, up), box),
            "first.first.outer",
            ["subtraction", "union"],
        ),
        (
            BooleanShape("union", box, PlacedShape(BooleanShape("intersection", rod, box), up)),
            "second.first.outer",
            ["intersection", "union"],
        ),
    ]
    for shape, face, ops in cases:
        clip = shape.face_clip(face)
        assert boolean_layers._clip_operations(shape, face) == ops
        # the clips of an intersection are from inside, the others from outside
        assert [inside for _, _, inside in clip.clips] == [op == "intersection" for op in ops]


@pytest.mark.deep
def test_a_piece_over_a_groove_cut_beside_the_wall_is_not_searched_there(gdml):
    """((rod | box) - half ring): the rod's wall above the box keeps no cell where the groove
    (r 5 to 8 mm, phi 0 to 180 degrees, up to z = 16 mm) runs beside it, but the rings keep
    cells at the other azimuths, so the piece above the box covers the full circle and passes
    through the groove, where the solid was removed. The search for a piece inside the solid's
    other parts looks only inside the union's other part (the box): a point of the piece is
    outside the rod, so it can be in the solid only there. Before, it searched inside the
    groove too, whose wall is the rod's face, and gave up (more than 2e6 cells for an 11 um
    layer: 'move them apart by a micrometre'; deep test below). No point of the envelope is
    inside the solid; some are in the groove (deep: ~21 s CPU with a cold cache, the nested
    boolean's face areas)."""
    layer = _layer(gdml, "groove")
    assert layer.pieces is not None
    on = layer.on_boolean
    assert boolean_layers._clip_operations(on.shape, on.face) == ["union", "subtraction"]
    assert _pieces_in_solid(layer, on.clip, on) is None
    above = [p for p in layer.pieces if p[2] > 0]
    assert len(above) == 1
    assert above[0][1] == pytest.approx(2 * np.pi, abs=1e-12)
    local = on.transform.inverse_apply(layer.shell_points(n_phi=144, n_v=81))
    assert not (on.shape.inside(local) == INSIDE).any()
    rho, phi = np.hypot(local[:, 0], local[:, 1]), np.arctan2(local[:, 1], local[:, 0])
    in_groove = (rho > 5) & (phi > 0) & (phi < np.pi) & (local[:, 2] > 10) & (local[:, 2] < 16)
    assert in_groove.any()


@pytest.mark.deep
def test_the_groove_was_refused_by_the_search_inside_it(gdml, monkeypatch):
    """The same rod's wall with the search inside every part from outside, the groove
    included (as before): refused in one line after more than 2e6 cells (deep: ~40 s CPU)."""
    monkeypatch.setattr(boolean_layers, "_clip_operations", lambda shape, name: ["union", "union"])
    with pytest.raises(ConfigError) as err:
        _layer(gdml, "groove")
    assert "needs more than 2000000 cells" in str(err.value)


@pytest.mark.deep
def test_the_groove_passes_geant4s_overlap_check(gdml, tmp_path):
    """The rod's wall of ``groove``, its piece above the box through the groove: Geant4's
    overlap check finds no overlap (deep)."""
    (tmp_path / "groove.yaml").write_text(yaml.safe_dump(config(gdml, ["groove"])))
    assert_no_overlaps(tmp_path / "groove.yaml")


def _rays(scene, rng: np.random.Generator) -> tuple[list, list, list]:
    """Rays (world) from 0.05 mm outside kept cells of each layer, near where its envelope ends
    (the hole's rim, the post's foot, the box's face), aimed at points inside the solid; the
    volume each is scored in."""
    starts, ways, owners = [], [], []
    for volume in CASES:
        layer = scene.layer(volume, CASES[volume][0])
        target = scene.target(volume)
        lay = layer.ring_layout
        kept = np.flatnonzero((layer.cell_variants >= 0).any(axis=1))
        near = (
            kept[(np.abs(lay.face.point(0.0, lay.v[kept])[:, 2]) > 1.2)]  # the hole's rim rings
            if volume == "orbhole"
            else (kept[-6:] if volume == "dome" else kept[:6])
        )
        cells = [c for c in layer.cells() if c[0] in set(near.tolist())]
        for _ in range(8):
            j, _i, _k, phi = cells[rng.integers(len(cells))]
            u = phi + rng.uniform(-0.3, 0.3) * lay.step[j]
            p = lay.face.point(u, lay.v[j]) + 0.05 * lay.face.normal(u, lay.v[j])
            o = layer.target.to_world(p[None])[0]
            aim = target.to_world(target.shape.sample_volume(rng, 1))[0]
            starts.append(o)
            ways.append((aim - o) / np.linalg.norm(aim - o))
            owners.append(volume)
    return starts, ways, owners


@pytest.mark.deep
def test_sphere_pieces_in_geant4(gdml, tmp_path):
    """The three layers together: Geant4's overlap check finds no overlap, and geantinos from
    just outside kept cells near each envelope's ends, aimed into the solid, travel in it the
    path in the solid (its signed distance, bisected) plus the path in the patch bodies near
    the ray, to 1e-9 mm (deep: ~30 s)."""
    data = config(gdml, list(CASES), output={"track_length": True})
    (tmp_path / "spheres.yaml").write_text(yaml.safe_dump(data))
    assert_no_overlaps(tmp_path / "spheres.yaml")
    cfg = parse_config(data)
    scene = build_scene(cfg)
    starts, ways, owners = _rays(scene, np.random.default_rng(17))
    n = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(ways), tmp_path)
    crossed = dict.fromkeys(CASES, 0)
    for k in range(n):
        volume, o, d = owners[k], starts[k], ways[k]
        target = scene.target(volume)
        layer = scene.layer(volume, CASES[volume][0])
        expected = polycone_path(target.to_local(o[None])[0], target.rotation.T @ d,
                                 target.shape, length=30.0)  # fmt: skip
        in_patches = patches_path(o, d, layer, 30.0)
        crossed[volume] += in_patches > 0
        got = float(np.asarray(r.scores["track_length"][volume])[k])
        assert got == pytest.approx(expected + in_patches, abs=1e-9, rel=0), (k, volume)
    assert all(c >= 4 for c in crossed.values()), crossed  # most rays cross a patch body


@pytest.mark.deep
def test_sphere_pieces_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The three layers written by `score4 geometry export`: Geant4 reads the file back with
    the same geantino paths (1e-9 mm), and so it reads the file pyg4ometry reads and writes
    again; rays cross each layer's patches."""
    cfg = tmp_path / "spheres.yaml"
    data = config(gdml, list(CASES))
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "spheres_rough.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    scene = build_scene(parse_config(data))
    starts, ways, _ = _rays(scene, np.random.default_rng(5))
    rays = [(o.tolist(), d.tolist()) for o, d in zip(starts, ways, strict=True)]
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    crossed = {v for path in ours for v, _ in path if v}
    for volume in CASES:
        assert any(v.startswith(f"{volume}_rough") for v in crossed), volume
    assert_same_paths(ours, back, relay)
