"""Rough layers on faces of boolean solids (score4.world.boolean_layers): a copper box less a
tube, LEGEND's P00664B (a PPC polycone less a box, with its pplus / passive / nplus groups) and a
union of two tubes; in numpy and in Geant4."""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from score4.cli.main import main
from score4.errors import ConfigError
from score4.geometry.check import curved_cells_tile
from score4.inputs.config import parse_config
from score4.runner.engine import run
from score4.runner.output import read_results
from score4.shapes.base import INSIDE, OUTSIDE
from score4.source.build import layer_sampler, make_source, source_geometry
from score4.world.resolve import build_scene
from score4.world.scene import CurvedRoughLayer

from helpers import g4_geometry_check
from helpers.boolean_worlds import CUTBOX_POSITION, STACK_POSITION, write_world
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
from helpers.spawn import run_in_spawned_process

#: 0.5 mm patches of 5 x 5 pyramids, 20 um high
PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}


def config(gdml: Path, rough: dict[str, list], **extra) -> dict:
    return geantino_config(
        gdml, {"p": PYRAMIDS}, rough_targets(rough), ("cutbox", "first.+z"), **extra
    )


ROUGH = {"cutbox": ["first.+z", "first.+x"], "stack": ["second.outer"]}
#: the cut face and the p+ contact of P00664B; the side wall with the p+ contact
PPC_ROUGH = {"ppc": ["second.-x", "pplus"]}
PPC_WALL_ROUGH = {"ppc": ["pplus", "first.seg_2"]}
#: all three: the wall's envelope holds its kept cells' azimuths, out of the cut face's way
PPC_ALL_ROUGH = {"ppc": ["second.-x", "pplus", "first.seg_2"]}


def assert_ppc_paths(data, cfg, scene, starts, directions, layers, tmp_path) -> None:
    """Geantinos from ``starts`` along ``directions`` through P00664B (``ppc``): each track
    length in Geant4 is the polycone's analytic path plus the paths in the patch bodies of
    ``layers``, to 1e-9 mm; most rays cross a patch body."""
    crystal = scene.target("ppc")
    n = len(starts)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    got = np.asarray(r.scores["track_length"]["ppc"])
    crossed = 0
    for k in range(n):
        o, d = starts[k], directions[k]
        expected = polycone_path(crystal.to_local(o[None])[0], crystal.rotation.T @ d,
                                 crystal.shape, length=80.0)  # fmt: skip
        in_patches = sum(patches_path(o, d, layer, 80.0) for layer in layers)
        crossed += in_patches > 0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2  # most rays cross a patch body


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    return write_world(tmp_path_factory.mktemp("boolean") / "boolean.gdml")


@pytest.fixture(scope="module")
def scene(gdml):
    return build_scene(parse_config(config(gdml, ROUGH)))


def _cell_points(layer) -> np.ndarray:
    """World points of every kept cell (a 5 x 5 grid reaching 0.499 of the cell) on the face."""
    px, py = layer.patch_size
    s = np.linspace(-0.499, 0.499, 5)
    off = np.stack(np.meshgrid(s * px, s * py), -1).reshape(-1, 2)
    if isinstance(layer, CurvedRoughLayer):
        lay = layer.ring_layout
        pts = []
        for j, _i, _, phi in layer.cells():
            step = lay.step[j]
            u = phi + off[:, 0] / px * step
            v = lay.v[j] + off[:, 1]
            pts.append(layer.target.to_world(lay.face.point(u, v)))
        return np.concatenate(pts)
    centres = layer.cell_centres()[layer.mask]
    xy = (centres[:, None, :] + off[None]).reshape(-1, 2)
    return layer.frame.to_world(np.column_stack([xy, np.zeros(len(xy))]))


def test_kept_cells_lie_wholly_on_the_boolean_surface(scene):
    """Each kept cell (25 points of it) lies on the boolean's surface: a hair against the
    face's normal is inside the solid, a hair along it outside; the rough share is the kept
    cells' area over the boolean face's (estimated) area (box less a tube, union of tubes)."""
    assert len(scene.layers) == 3
    _check_kept_cells(scene)


@pytest.mark.deep
def test_kept_cells_on_the_cut_detector_lie_on_its_surface(gdml):
    """As above on P00664B: the box's face that cuts the crystal and the p+ contact; the side
    wall less the cut and the p+ contact; all three together (the wall's cells and those of
    the cut face the same as without the other)."""
    masks = []
    for rough in (PPC_ROUGH, PPC_WALL_ROUGH, PPC_ALL_ROUGH):
        scene = build_scene(parse_config(config(gdml, rough)))
        assert len(scene.layers) == len(rough["ppc"])
        _check_kept_cells(scene)
        masks.append({layer.config.face_name: layer.mask for layer in scene.layers})
    for face in ("second.-x", "first.seg_2"):
        alone = masks[0] if face in masks[0] else masks[1]
        assert (masks[2][face] == alone[face]).all(), face


#: the cut face of P00664B and the side wall it cuts
PPC_CUT_AND_WALL = {"ppc": ["second.-x", "first.seg_2"]}


def test_the_cut_face_and_the_side_wall_it_cuts_build_together(gdml):
    """The side wall's envelope holds only the azimuths of its kept cells (one G4Tubs segment),
    so it stays out of the cut (x > 30 mm), where the cut face's layer stands, and both layers
    build (before, the whole shell ran through the cut: Geant4 found the envelopes
    overlapping by ~10 um). Every kept cell lies in the piece; the cells and shares are those
    of the wall alone (the deep test above)."""
    scene = build_scene(parse_config(config(gdml, PPC_CUT_AND_WALL)))
    wall = scene.layer("ppc", "first.seg_2")
    assert isinstance(wall, CurvedRoughLayer)
    assert wall.pieces is not None
    assert len(wall.pieces) == 1
    ((phi0, dphi, v0, v1, normal_ends),) = wall.pieces
    assert not normal_ends  # a cylinder's piece ends on z planes
    (_, _), (fv0, fv1) = wall.ring_layout.face.extent
    assert (v0, v1) == (fv0, fv1)  # a cone or cylinder piece spans the face's length
    crystal = scene.target("ppc")
    shell = crystal.to_local(wall.shell_points(n_phi=720))
    assert shell[:, 0].max() < 30.0  # out of the cut
    for j, _i, _k, phi in wall.cells():  # every kept cell wholly in the piece's azimuths
        step = wall.ring_layout.step[j]
        a = np.mod(phi - step / 2 - phi0, 2 * np.pi)
        assert a + step <= dphi + 1e-12
    assert scene.layer("ppc", "second.-x").mask.sum() > 0


@pytest.mark.deep
def test_the_cut_face_and_the_side_wall_in_geant4(gdml, tmp_path):
    """P00664B with its cut face and side wall rough: Geant4's own overlap check finds no
    overlap, and geantinos through both layers into the crystal (from beyond the cut and from
    outside the wall, near the cut's edge too) travel in it the analytic path in the polycone
    less the box plus the path in the patch bodies near the ray, to 1e-9 mm."""
    data = config(gdml, PPC_CUT_AND_WALL, output={"track_length": True})
    (tmp_path / "ppc.yaml").write_text(yaml.safe_dump(data))
    assert_no_overlaps(tmp_path / "ppc.yaml")
    cfg = parse_config(data)
    scene = build_scene(cfg)
    crystal = scene.target("ppc")
    cut, wall = scene.layer("ppc", "second.-x"), scene.layer("ppc", "first.seg_2")
    assert isinstance(wall, CurvedRoughLayer)
    rng = np.random.default_rng(11)
    starts, directions = [], []
    phi0, dphi, *_ = wall.pieces[0]
    for k in range(16):
        if k < 6:  # from beyond the cut face, through its layer
            o = np.array([30.05, rng.uniform(-15, 15), rng.uniform(6, 24)])
        else:  # from outside the wall (the last ones at the piece's edges, near the cut)
            phi = phi0 + (rng.uniform(0, 0.05) if k % 2 else dphi - rng.uniform(0, 0.05))
            phi = phi if k >= 10 else rng.uniform(phi0, phi0 + dphi)
            o = np.array([35.06 * np.cos(phi), 35.06 * np.sin(phi), rng.uniform(6, 24)])
        aim = crystal.shape.sample_volume(rng, 1)[0]
        starts.append(crystal.to_world(o[None])[0])
        d = (aim - o) / np.linalg.norm(aim - o)
        directions.append(crystal.rotation @ d)
    assert_ppc_paths(data, cfg, scene, starts, directions, [cut, wall], tmp_path)


#: the cut face of P00664B and its lower taper (a cone, r 33 -> 35 mm over z 0 -> 2 mm)
PPC_CUT_AND_TAPER = {"ppc": ["second.-x", "first.seg_1"]}


@pytest.mark.parametrize("taper_face", ["first.seg_1", "first.seg_3"])
def test_the_cut_face_and_a_taper_build_together(gdml, taper_face):
    """Every ring of P00664B's taper (seg_1 at the bottom, seg_3 at the top) keeps cells, over
    azimuths narrowing towards its wide end (each ring has its own grid of azimuths), and
    neighbouring rings' cells overlap in z, so no piece ending on z planes can leave the cut
    (x > 30 mm) at the wide end. The pieces end on the rings' band cones instead
    (``normal_ends``), one per ring here, each over its own ring's kept azimuths: the envelope
    stays out of the cut, where the cut face's layer stands, and both build (refused before,
    with the gap). Neighbouring pieces share their band cone exactly; each piece holds its
    ring's cells (exact tiling), and (seg_1) a piece cut short by 1e-6 mm along the generator
    is flagged, as is one reaching 1e-6 mm into the next."""
    scene = build_scene(parse_config(config(gdml, {"ppc": ["second.-x", taper_face]})))
    taper = scene.layer("ppc", taper_face)
    assert isinstance(taper, CurvedRoughLayer)
    lay = taper.ring_layout
    kept = taper.cell_variants >= 0
    assert kept.any(axis=1).all()  # every ring keeps cells
    assert taper.pieces is not None
    assert len(taper.pieces) == len(lay.v)  # each ring keeps other azimuths than its neighbour
    assert all(p.normal_ends for p in taper.pieces)
    half = 0.5 * (lay.patch_size[1] + lay.row_gap)
    for j, p in enumerate(sorted(taper.pieces, key=lambda p: p.v0)):
        assert (p.v0, p.v1) == pytest.approx((lay.v[j] - half, lay.v[j] + half), abs=1e-12)
        phi = lay.cell_phi(j)[kept[j, : lay.count[j]]]
        assert p.phi0 == pytest.approx(phi.min() - lay.step[j] / 2, abs=1e-12)
        assert p.phi0 + p.dphi == pytest.approx(phi.max() + lay.step[j] / 2, abs=1e-12)
    ends = sorted(taper.pieces, key=lambda p: p.v0)
    assert all(a.v1 == b.v0 for a, b in itertools.pairwise(ends))  # one band cone
    crystal = scene.target("ppc")
    shell = crystal.to_local(taper.shell_points(n_phi=2000))
    assert shell[:, 0].max() < 30.0  # out of the cut
    on = taper.on_boolean
    codes = on.shape.inside(on.transform.inverse_apply(taper.shell_points(n_v=21)))
    assert not (codes == INSIDE).any()
    assert scene.layer("ppc", "second.-x").mask.sum() > 0
    assert not curved_cells_tile(taper)[1]
    if taper_face != "first.seg_1":
        return
    a = ends[2]
    taper.pieces = [*ends[:2], a._replace(v1=a.v1 - 1e-6), *ends[3:]]  # a ring's band cut short
    assert any("outside the pieces" in p for p in curved_cells_tile(taper)[1])
    taper.pieces = [*ends[:2], a._replace(v1=a.v1 + 1e-6), *ends[3:]]  # into the next piece
    assert curved_cells_tile(taper)[1] == [
        f"{taper.name}: pieces 2 and 3 of the envelope overlap by 0.001 um along the face"
    ]


@pytest.mark.deep
def test_the_cut_face_and_a_taper_in_geant4(gdml, tmp_path, monkeypatch):
    """P00664B with its cut face and lower taper rough (the taper's envelope in pieces ending on
    its rings' band cones, G4GenericPolycone segments): Geant4's own overlap check finds no
    overlap, and geantinos through both layers into the crystal (from beyond the cut, from
    outside the taper at its pieces' azimuth edges near the cut, across its band cones) travel
    in it the analytic path in the polycone less the box plus the path in the patch bodies near
    the ray, to 1e-9 mm; the world exported to GDML and read back by Geant4 and pyg4ometry
    gives the same paths."""
    data = config(gdml, PPC_CUT_AND_TAPER, output={"track_length": True})
    (tmp_path / "ppc.yaml").write_text(yaml.safe_dump(data))
    assert_no_overlaps(tmp_path / "ppc.yaml")
    # the check can fail: the third piece's end moved 10 um past its band cone into the fourth
    found = run_in_spawned_process(
        g4_geometry_check.check_moved_piece, data, "first.seg_1", 2, 0.01
    )
    assert any("ppc_roughfirst_seg_1_env" in line for line in found), found
    cfg = parse_config(data)
    scene = build_scene(cfg)
    crystal = scene.target("ppc")
    cut, taper = scene.layer("ppc", "second.-x"), scene.layer("ppc", "first.seg_1")
    assert isinstance(taper, CurvedRoughLayer)
    face = taper.ring_layout.face
    rng = np.random.default_rng(5)
    starts, directions = [], []
    pieces = sorted(taper.pieces, key=lambda p: p.v0)
    for k in range(16):
        if k < 4:  # from beyond the cut face, through its layer, low (near the taper)
            o = np.array([30.05, rng.uniform(-15, 15), rng.uniform(0.2, 4)])
        else:  # from outside the taper: at a piece's azimuth edge (by the cut) or anywhere,
            # at a band cone between two pieces or anywhere along the generator
            p = pieces[k % len(pieces)]
            phi = p.phi0 + (rng.uniform(0, 0.02) if k % 2 else p.dphi - rng.uniform(0, 0.02))
            phi = phi if k < 12 else rng.uniform(p.phi0, p.phi0 + p.dphi)
            v = p.v1 if k % 3 == 0 and p is not pieces[-1] else rng.uniform(p.v0, p.v1)
            o = face.point(phi, v) + 0.05 * face.normal(phi, v)
        aim = crystal.shape.sample_volume(rng, 1)[0]
        aim[2] = min(aim[2], 6.0) if k >= 4 else aim[2]  # through the taper, not the side
        starts.append(crystal.to_world(o[None])[0])
        d = (aim - o) / np.linalg.norm(aim - o)
        directions.append(crystal.rotation @ d)
    assert_ppc_paths(data, cfg, scene, starts, directions, [cut, taper], tmp_path)
    out = tmp_path / "ppc_rough.gdml"
    assert main(["geometry", "export", str(tmp_path / "ppc.yaml"), "--gdml", str(out)]) == 0
    rays = [(o.tolist(), d.tolist()) for o, d in zip(starts, directions, strict=True)]
    ours, back, relay = three_paths(tmp_path / "ppc.yaml", out, rays, monkeypatch)
    names = {v for path in ours for v, _ in path if v}
    for j in range(len(pieces)):  # cells of every ring (each its own piece), the cut face's
        assert any(v.startswith(f"{taper.name}_v0_r{j}") for v in names), j
    assert any(v.startswith(cut.name) for v in names)
    # (the export numbers the cut face's repeated group placements once more: g1_0 -> g1_0_3)
    assert_same_paths(ours, back, relay, names=_unnumbered)


def _unnumbered(name: str | None) -> str | None:
    """A volume name without any of the export's trailing numbers (:func:`base_name`)."""
    name = base_name(name)
    return name and re.sub(r"(_\d+)+$", "", name)


def _check_kept_cells(scene) -> None:
    for layer in scene.layers:
        on = layer.on_boolean
        assert on is not None
        pts = _cell_points(layer)
        local = on.transform.inverse_apply(pts)
        n = layer.frame.normal if not isinstance(layer, CurvedRoughLayer) else None
        if n is None:  # a cylinder wall: the radial direction (outward)
            q = layer.target.to_local(pts)
            radial = np.column_stack([q[:, 0], q[:, 1], np.zeros(len(q))])
            radial /= np.linalg.norm(radial, axis=1, keepdims=True)
            nl = radial @ on.clip.transform.rotation.T
        else:
            nl = np.tile(n @ on.transform.rotation, (len(pts), 1))
        assert (on.shape.inside(local - 1e-6 * nl) == INSIDE).all(), layer.name
        assert (on.shape.inside(local + 1e-6 * nl) == OUTSIDE).all(), layer.name
        px, py = layer.patch_size
        if not isinstance(layer, CurvedRoughLayer):
            share = layer.mask.sum() * px * py / on.shape.face_areas[on.face]
            assert layer.rough_share == pytest.approx(share, rel=1e-12)
        assert 0.5 < layer.rough_share <= 1.0 + 4e-3


def test_the_box_face_around_the_hole_keeps_the_cells_clear_of_it(scene):
    """On the +z face of the box less the tube (r 5 mm): the kept cells are those whose
    rectangle stays out of the hole or touches its rim (an exact count from the cells' nearest
    points to the axis), less at most the cells within 0.01 mm of the hole's rim (left
    unproven)."""
    layer = scene.layer("cutbox", "first.+z")
    px, py = layer.patch_size
    c = layer.cell_centres()
    centre = layer.frame.to_local(np.array([CUTBOX_POSITION]))[0, :2]
    d = c - centre
    nearest = np.hypot(
        np.maximum(np.abs(d[..., 0]) - px / 2, 0), np.maximum(np.abs(d[..., 1]) - py / 2, 0)
    )
    clear = nearest >= 5.0  # a cell may touch the hole's rim (its bounding box proves it)
    assert not (layer.mask & ~clear).any()
    rim = clear & (nearest < 5.01)
    assert not (clear & ~layer.mask & ~rim).any()
    assert layer.mask.sum() > 0.95 * clear.sum()
    assert scene.layer("cutbox", "first.+x").mask.all()  # the hole does not reach +x


def test_samples_lie_on_the_patches_and_the_flat_rest_on_the_surface(gdml, scene):
    """A source on the rough +z face of the box less the tube: points on the patch tops or on
    the flat rest, which lies on the boolean's surface and outside every rough cell; the flat
    share is the rest's share of the area (4 sigma); the area carries the estimate's error."""
    data = config(gdml, ROUGH)
    data["source"]["surface"] = {"volume": "cutbox", "face": "first.+z"}
    cfg = parse_config(data)
    n = 4000
    p = make_source(cfg, scene).primaries(np.random.default_rng(4), 0, n)
    layer = scene.layer("cutbox", "first.+z")
    geo = source_geometry(cfg, scene)
    tops = layer_sampler(layer).area
    on = layer.on_boolean
    flat = on.shape.face_areas[on.face] - layer.mask.sum() * np.prod(layer.patch_size)
    assert geo["area_mm2"] == pytest.approx(tops + flat, rel=1e-9)
    assert geo["area_error_mm2"] == pytest.approx(on.shape.face_area_errors[on.face], rel=1e-9)
    assert geo["area_error_mm2"] > 0
    on_flat = p.extra["patch"] < 0
    share = flat / geo["area_mm2"]
    assert abs(on_flat.mean() - share) < 4 * math.sqrt(share * (1 - share) / n)
    local = on.transform.inverse_apply(p.position[on_flat])
    assert np.abs(on.shape.signed_distance(local)).max() < 1e-9
    xy = layer.frame.to_local(p.position[on_flat])[:, :2]
    i, j = layer.patch_map.cell_of(xy)
    inside = i >= 0
    assert (layer.cell_variants[j[inside], i[inside]] < 0).all()
    assert scene.inside_target("cutbox", p.position).all()


def _box_less_tube_path(o: np.ndarray, d: np.ndarray) -> float:
    """Path of a ray (box frame) in the box |x|,|y|,|z| < 10 less the cylinder r < 5."""
    t0, t1 = -np.inf, np.inf
    for k in range(3):
        if abs(d[k]) < 1e-15:
            continue
        a, b = (-10 - o[k]) / d[k], (10 - o[k]) / d[k]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    t0 = max(t0, 0.0)
    if t1 <= t0:
        return 0.0
    a = d[0] ** 2 + d[1] ** 2
    b = 2 * (o[0] * d[0] + o[1] * d[1])
    c = o[0] ** 2 + o[1] ** 2 - 25
    disc = b * b - 4 * a * c
    if a < 1e-15 or disc <= 0:
        return t1 - t0
    c0, c1 = (-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)
    overlap = max(0.0, min(t1, c1) - max(t0, c0))
    return t1 - t0 - overlap


def test_geantino_paths_agree_with_an_independent_ray_trace(gdml, scene, tmp_path):
    """Geantinos from just above kept cells of the +z face of the box less the tube, aimed at
    points of the solid: Geant4's track length in the target equals the analytic path in the
    box less the cylinder plus the path in the patch bodies near the ray, to 1e-9 mm."""
    data = config(gdml, {"cutbox": ["first.+z"]}, output={"track_length": True})
    cfg = parse_config(data)
    one = build_scene(cfg)
    layer = one.layer("cutbox", "first.+z")
    target = one.target("cutbox")
    rng = np.random.default_rng(7)
    centres = layer.cell_centres()[layer.mask]
    starts, directions = [], []
    for _ in range(12):
        c = centres[rng.integers(len(centres))] + rng.uniform(-0.2, 0.2, 2)
        start = layer.frame.to_world(np.array([*c, 0.03]))
        aim = target.to_world(target.shape.sample_volume(rng, 1))[0]
        starts.append(start)
        directions.append((aim - start) / np.linalg.norm(aim - start))
    n = len(starts)
    primaries = make_source(cfg, one).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(data, primaries, np.array(starts), np.array(directions), tmp_path)
    for k in range(n):
        o, d = starts[k], directions[k]
        expected = _box_less_tube_path(target.to_local(o[None])[0], d @ target.rotation)
        expected += flat_patches_path(layer, o, d)
        got = r.scores["track_length"]["cutbox"][k]
        assert got == pytest.approx(expected, abs=1e-9, rel=0), k


#: 0.4 mm patches of 5 x 5 pyramids, 20 um high: fine enough to bend onto the 5 mm bore
FINE = {**PYRAMIDS, "width": "80 um"}


@pytest.fixture(scope="module")
def bore(gdml):
    """The box less a tube with the bore's wall rough (the subtracted tube's outer wall, the
    layer on the bore's side) and the +z face around it."""
    data = config(gdml, {"cutbox": ["second.outer", "first.+z"]}, output={"track_length": True})
    data["surfaces"] = {"p": FINE}
    return data


def test_a_bore_takes_a_rough_layer_inside_it(bore):
    """The bore's wall: the layer lies inside the hole (its patches between the wall and the
    axis, their tops towards it); the kept cells lie on the boolean's surface (a hair towards
    the axis is outside the solid, a hair away inside); every cell not touching the box's end
    faces is kept; its shell ends where the box does, below the +z face's layer."""
    scene = build_scene(parse_config(bore))
    layer = scene.layer("cutbox", "second.outer")
    assert isinstance(layer, CurvedRoughLayer)
    on = layer.on_boolean
    pts = on.transform.inverse_apply(_cell_points(layer))
    radial = np.column_stack([pts[:, 0], pts[:, 1], np.zeros(len(pts))])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert (on.shape.inside(pts + 1e-6 * radial) == INSIDE).all()
    assert (on.shape.inside(pts - 1e-6 * radial) == OUTSIDE).all()
    shell = on.transform.inverse_apply(layer.shell_points())
    r = np.hypot(shell[:, 0], shell[:, 1])
    assert r.max() <= 5 + 1e-9
    assert r.min() >= 5 - layer.thickness - 1e-9
    assert np.abs(shell[:, 2]).max() <= 10 + 1e-9
    lay = layer.ring_layout
    inner = np.abs(lay.v) < 10 - layer.patch_size[1]  # rows clear of the box's end faces
    assert (layer.mask[inner] == (layer.cell_variants[inner] >= 0)).all()
    assert layer.mask[inner].all()
    assert 0.95 < layer.rough_share < 1
    share = layer.mask.sum() * np.prod(layer.patch_size) / on.shape.face_areas[on.face]
    assert layer.rough_share == pytest.approx(share, rel=1e-12)


def test_geantino_paths_through_a_rough_bore(bore, tmp_path):
    """Geantinos from near the bore's axis, out through the rough wall into the box: Geant4's
    track length in the target equals the analytic path in the box less the cylinder plus the
    path in the bent patch bodies near the crossing, to 1e-9 mm."""
    cfg = parse_config(bore)
    scene = build_scene(cfg)
    layer = scene.layer("cutbox", "second.outer")
    target = scene.target("cutbox")
    rng = np.random.default_rng(13)
    n = 10
    phi, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-7, 7, n)
    local = np.column_stack([np.cos(phi), np.sin(phi), z])  # at radius 1 mm
    out = np.column_stack(
        [np.cos(phi + 0.3), np.sin(phi + 0.3), rng.uniform(-0.3, 0.3, n)]
    )  # outwards, tilted
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    starts, directions = target.to_world(local), out @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    r = geantino_run(bore, primaries, starts, directions, tmp_path)
    got = np.asarray(r.scores["track_length"]["cutbox"])
    crossed = 0
    for k in range(n):
        o, d = local[k], out[k]
        expected = _box_less_tube_path(o, d)
        a, b = d[0] ** 2 + d[1] ** 2, 2 * (o[0] * d[0] + o[1] * d[1])
        t = (-b + math.sqrt(b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - 25))) / (2 * a)
        hit = o + t * d  # where the ray leaves the bore
        assert abs(hit[2]) < 9
        tri = wall_patches_near(layer, target, hit, 2 / 5)
        in_patches = mesh_path(o, d, tri, edge=1e-12, merge=1e-10)
        crossed += in_patches > 0
        assert got[k] == pytest.approx(expected + in_patches, abs=1e-9, rel=0), k
    assert crossed >= n // 2  # most rays cross a patch body, not only the gaps between


def test_rough_boolean_faces_export_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The box less a tube with its +z face (around the bore) and +x face rough, and the union
    of two tubes with the upper tube's wall rough, written by `score4 geometry export`: Geant4
    reads the file back with the same geantino paths (1e-9 mm), and so it reads the file
    pyg4ometry reads and writes again (issue 24 item 5)."""
    data = config(gdml, ROUGH)
    cfg = tmp_path / "boolean.yaml"
    cfg.write_text(yaml.safe_dump(data))
    out = tmp_path / "boolean_rough.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(11)
    rays = []
    box = np.array(CUTBOX_POSITION)
    for axis in (2, 0):  # from 0.5 mm above +z (some over the bore) and +x, into the box
        for _ in range(5):
            start = box + rng.uniform(-9.5, 9.5, 3)
            start[axis] = box[axis] + 10.5
            aim = box + rng.uniform(-9.5, 9.5, 3)
            rays.append((start, aim - start))
    stack = np.array(STACK_POSITION)
    for _ in range(5):  # from 0.5 mm outside the upper tube's wall (r 7 mm, z 5 to 15), inwards
        phi, z = rng.uniform(0, 2 * np.pi), rng.uniform(6, 14)
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        rays.append((stack + 7.5 * radial + [0, 0, z], -radial + [0, 0, rng.uniform(-0.3, 0.3)]))
    rays = [(o.tolist(), (d / np.linalg.norm(d)).tolist()) for o, d in rays]
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    crossed = {base_name(v) for path in ours for v, _ in path}
    for layer in ("cutbox_roughfirst_pz", "cutbox_roughfirst_px", "stack_roughsecond_outer"):
        assert any(v and v.startswith(layer) for v in crossed), layer  # each layer's patches
    assert_same_paths(ours, back, relay)


def test_hpge_groups_resolve_on_a_detector_with_a_cut(gdml):
    """P00664B (a PPC polycone less a box): its pplus / passive / nplus groups name faces of
    the polycone inside the boolean; their areas are the polycone faces' less the cut (the
    bottom annulus and the cylinder wall lose the part beyond x = 30 mm); the p+ contact is
    whole."""
    s = build_scene(parse_config(config(gdml, {"ppc": []}))).target("ppc").shape
    assert s.groups["pplus"] == ("first.seg_0a",)
    assert s.groups["passive"] == ("first.seg_0b",)
    assert s.groups["nplus"] == ("first.seg_1", "first.seg_2", "first.seg_3", "first.seg_4")
    assert s.face_areas["first.seg_0a"] == pytest.approx(math.pi * 4, rel=1e-9)
    wall = 2 * math.pi * 35 * 26  # r 35 mm, 26 mm between the tapers
    cut = 2 * math.acos(30 / 35) * 35 * 26
    err = s.face_area_errors["first.seg_2"]
    assert s.face_areas["first.seg_2"] == pytest.approx(wall - cut, abs=4 * err)
    assert err < 1e-3 * (wall - cut)


@pytest.mark.deep
def test_a_rough_pplus_and_cut_face_run_in_geant4(gdml, tmp_path):
    """Po-210 alphas on the rough cut face and side wall of P00664B, its p+ contact rough too:
    Geant4 builds the layers, and over 30 % of the events deposit energy in the detector."""
    data = config(
        gdml,
        PPC_ALL_ROUGH,
        source={
            "particle": "alpha",
            "energy": "5.3 MeV",
            "surface": {"volume": "ppc", "face": ["second.-x", "first.seg_2"]},
        },
    )
    data["run"] = {"events": 30, "seed": 5}
    r = read_results(
        run(parse_config(data), tmp_path / "a.h5", progress=False, echo=lambda m: None)
    )
    edep = np.asarray(r.scores["edep"]["ppc"])
    assert len(edep) == 30
    assert (edep > 0).mean() > 0.3


@pytest.mark.parametrize(
    ("volume", "face", "extra", "message"),
    [
        (
            "cutbox",
            "first.+q",
            {},
            "no face 'first.+q' on a G4SubtractionSolid; its faces: first.+x",
        ),
        ("cutbox", "second.+z", {"into": True}, "face second.+z of 'cutbox' (a G4Subtraction"),
        ("cutbox", "second.+z", {}, "lies nowhere on the solid's surface"),
        ("cutbox", "first.+z", {"native_layout": "replicas"}, "native_layout replicas fills"),
    ],
)
def test_bad_boolean_layers_are_one_line_errors(gdml, volume, face, extra, message):
    data = config(gdml, {volume: [face]})
    data["targets"][0]["rough"][0].update(extra)
    with pytest.raises(ConfigError, match=None) as err:
        build_scene(parse_config(data))
    assert message in str(err.value)
    assert "\n" not in str(err.value)
