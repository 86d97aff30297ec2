"""``into: true`` on a flat face of a subtracted G4Box (score4.world.boolean_modes): a copper
box with a square pocket cut into its top (a box less a box); the subtracted box grows by the
layer's thickness along the face's own normal, into the kept copper, and the layer lies in the
slab, its top where the face was. Geantino paths against an analytic ray trace of the box less
the grown pocket and the patch bodies near each ray, 1e-9 mm."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from score4.inputs.config import parse_config
from score4.world.resolve import build_scene

from helpers.geantinos import geantino_config, rough_targets
from helpers.ray_trace import flat_patches_path

PYRAMIDS = {"kind": "spikes", "nx": 5, "ny": 5, "width": "100 um", "height": "20 um"}
HALF = 10.0  # the box's half width, mm
#: the pocket: a subtracted box of half widths (3, 3, 5) mm at (0, 0, 10): 6 x 6 mm, 5 mm deep
POCKET_HALF, POCKET_AT = np.array([3.0, 3.0, 5.0]), np.array([0.0, 0.0, 10.0])


@pytest.fixture(scope="module")
def gdml(tmp_path_factory) -> Path:
    """The box less the pocket and a box less a blind hole (a G4Tubs of r 3 mm from z = 5 mm up,
    at y = 30 mm), written by pyg4ometry (the floors of other holes:
    tests/test_into_subtracted_faces.py)."""
    import pyg4ometry as pg

    reg = pg.geant4.Registry()
    s = pg.geant4.solid
    world = pg.geant4.LogicalVolume(s.Box("world_s", 100, 100, 100, reg), "G4_Galactic", "W", reg)
    box = s.Box("pocket_a", 2 * HALF, 2 * HALF, 2 * HALF, reg)
    hole = s.Box("pocket_b", *(2 * POCKET_HALF).tolist(), reg)
    cut = s.Subtraction("pocket_s", box, hole, [[0, 0, 0], POCKET_AT.tolist()], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "pocket_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 0, 0], lv, "pocket", world, reg)
    box = s.Box("blind_a", 2 * HALF, 2 * HALF, 2 * HALF, reg)
    tube = s.Tubs("blind_b", 0, 3, 10, 0, 2 * np.pi, reg)
    cut = s.Subtraction("blind_s", box, tube, [[0, 0, 0], [0, 0, 10]], reg)
    lv = pg.geant4.LogicalVolume(cut, "G4_Cu", "blind_lv", reg)
    pg.geant4.PhysicalVolume([0, 0, 0], [0, 30, 0], lv, "blind", world, reg)
    reg.setWorld(world.name)
    path = tmp_path_factory.mktemp("subinto") / "pocket.gdml"
    writer = pg.gdml.Writer()
    writer.addDetector(reg)
    writer.write(str(path))
    return path


def config(gdml: Path, face: str, volume: str = "pocket") -> dict:
    targets = rough_targets({volume: [face]}, into=True)
    return geantino_config(
        gdml, {"p": PYRAMIDS}, targets, (volume, "first.-z"), output={"track_length": True}
    )


def _grown(face: str, t: float) -> tuple[np.ndarray, np.ndarray]:
    """The pocket grown by ``t`` behind ``face`` (its own face name): (lo, hi), mm."""
    lo, hi = POCKET_AT - POCKET_HALF, POCKET_AT + POCKET_HALF
    axis = "xyz".index(face[1])
    if face[0] == "+":
        hi[axis] += t
    else:
        lo[axis] -= t
    return lo, hi


def _slab(o: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[float, float]:
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    t1 = np.where(d == 0, np.where((o >= lo) & (o <= hi), -np.inf, np.inf), t1)
    t2 = np.where(d == 0, np.where((o >= lo) & (o <= hi), np.inf, -np.inf), t2)
    return max(float(np.max(np.minimum(t1, t2))), 0.0), float(np.min(np.maximum(t1, t2)))


def _box_less_pocket(o: np.ndarray, d: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Path of the ray o + s d (s > 0) in the box [-10, 10]^3 less the box [lo, hi]."""
    s0, s1 = _slab(o, d, np.full(3, -HALF), np.full(3, HALF))
    if s1 <= s0:
        return 0.0
    c0, c1 = _slab(o, d, lo, hi)
    return (s1 - s0) - max(0.0, min(s1, c1) - max(s0, c0))


def test_into_the_pocket_floor_grows_the_pocket(gdml):
    """into: true on the pocket's floor (face -z of the subtracted box, z = 5 mm): the layer's
    base lies t below it, its normal up (out of the copper), all 12 x 12 cells on the grown
    floor (a hair below: copper; a hair above: out of it), and the slab is no longer copper
    unless in a patch."""
    scene = build_scene(parse_config(config(gdml, "second.-z")))
    layer = scene.layer("pocket", "second.-z")
    target = scene.target("pocket")
    t = layer.thickness
    assert target.to_local(layer.frame.centre[None])[0] == pytest.approx([0, 0, 5.0 - t], abs=1e-12)
    assert target.rotation.T @ layer.frame.normal == pytest.approx([0, 0, 1], abs=1e-12)
    assert layer.mask.sum() == 144
    on = layer.on_boolean
    centres = layer.cell_centres()[layer.mask]
    pts = on.transform.inverse_apply(
        layer.frame.to_world(np.column_stack([centres, np.zeros(len(centres))]))
    )
    assert (on.shape.inside(pts - np.array([0, 0, 1e-6])) == 2).all()
    assert (on.shape.inside(pts + np.array([0, 0, 1e-6])) == 0).all()
    slab = target.to_world(np.array([[1.0, 1.0, 5.0 - t / 2], [1.0, 1.0, 5.0 - t - 1e-3]]))
    inside = scene.inside_target("pocket", slab)
    assert inside[1]
    assert inside[0] == layer.contains(slab[:1])[0]


@pytest.mark.parametrize(
    "faces",
    [
        ["second.-z"],
        pytest.param(["second.+x"], marks=pytest.mark.deep),
        pytest.param(["second.-z", "second.+x"], marks=pytest.mark.deep),
    ],
    ids=["floor", "wall", "both"],
)
def test_geantino_paths_through_a_grown_pocket(gdml, faces, tmp_path):
    """Geantinos from inside the pocket, down through its floor or out through its +x wall
    (there only the part below the box's top, z 5 to 10 mm, holds patches), or both layers at
    once (the t x t edge between their slabs belongs to neither): Geant4's track length in the
    target (the boolean rebuilt around the grown box) equals the analytic path in the box less
    the pocket grown by t behind the faces plus the path in the patch bodies near the ray,
    1e-9 mm."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run

    data = config(gdml, faces[0])
    for face in faces[1:]:
        data["targets"][0]["rough"].append({"face": face, "surface": "p", "into": True})
    cfg = parse_config(data)
    scene = build_scene(cfg)
    layers = [scene.layer("pocket", face) for face in faces]
    t = layers[0].thickness
    lo, hi = POCKET_AT - POCKET_HALF, POCKET_AT + POCKET_HALF
    for face, layer in zip(faces, layers, strict=True):
        axis, sign = "xyz".index(face[-1]), 1.0 if face[-2] == "+" else -1.0
        grown = _grown(face[-2:], t)
        lo, hi = np.minimum(lo, grown[0]), np.maximum(hi, grown[1])
        out = -sign * np.eye(3)[axis]  # the boolean's outward normal: into the pocket
        assert layer.frame.normal == pytest.approx(out, abs=1e-12)  # the target is unrotated
        face_at = (POCKET_AT + sign * POCKET_HALF)[axis]
        assert layer.frame.centre[axis] == pytest.approx(face_at + sign * t, abs=1e-12)
        if face == "second.+x":  # 12 cells across, 10 rows below the box's top (z 5 to 10 mm)
            assert layer.mask.sum() == 120
    rng = np.random.default_rng(5)
    n = 10
    if faces == ["second.-z"]:
        starts = np.column_stack([rng.uniform(-2.8, 2.8, (n, 2)), np.full(n, 9.0)])
        aims = np.column_stack([rng.uniform(-9, 9, (n, 2)), np.full(n, -9.0)])
    else:  # out through the wall, or (both faces) some through the floor and the edge
        low = 5.5 if len(faces) == 1 else -3.0
        starts = np.column_stack([np.full(n, -2.0), rng.uniform(-2, 2, n), rng.uniform(7, 9, n)])
        aims = np.column_stack([np.full(n, 9.0), rng.uniform(-2.5, 2.5, n), rng.uniform(low, 9, n)])
    directions = (aims - starts) / np.linalg.norm(aims - starts, axis=1, keepdims=True)
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    got = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(got.scores["track_length"]["pocket"])
    crossed = np.zeros(len(layers), dtype=int)
    for k in range(n):
        o, d = starts[k], directions[k]  # the target sits at the origin, unrotated
        in_patches = [flat_patches_path(layer, o, d) for layer in layers]
        crossed += np.array(in_patches) > 0
        expected = _box_less_pocket(o, d, lo, hi) + sum(in_patches)
        assert got[k] == pytest.approx(expected, abs=1e-9, rel=0), k
    assert (crossed >= 2).all()
    assert crossed.sum() >= n // 2


@pytest.mark.deep
def test_a_grown_pocket_exports_with_the_same_paths(gdml, tmp_path, monkeypatch):
    """The box less the pocket grown for an into layer on its floor, written by `score4
    geometry export`: Geant4 reads the file back, and the file pyg4ometry reads and writes
    again, with the same geantino paths (volumes and points, 1e-9 mm)."""
    import yaml

    from score4.cli.main import main

    from helpers.export_paths import assert_same_paths, three_paths

    cfg = tmp_path / "into.yaml"
    cfg.write_text(yaml.safe_dump(config(gdml, "second.-z")))
    out = tmp_path / "into.gdml"
    assert main(["geometry", "export", str(cfg), "--gdml", str(out)]) == 0
    rng = np.random.default_rng(11)
    rays = []
    for _ in range(8):  # from inside the pocket, down through its floor
        start = np.array([*rng.uniform(-2.8, 2.8, 2), 9.0])
        d = np.array([*rng.uniform(-9, 9, 2), -9.0]) - start
        rays.append((start.tolist(), (d / np.linalg.norm(d)).tolist()))
    ours, back, relay = three_paths(cfg, out, rays, monkeypatch)
    assert_same_paths(ours, back, relay)
    assert sum(any("rough" in (v or "") for v, _ in path) for path in ours) >= 4


@pytest.mark.deep
def test_into_the_cut_face_of_a_legend_detector(tmp_path):
    """LEGEND's P00664B (a PPC polycone less a box beyond x = 30 mm): into: true on the box's
    face that cuts the crystal (second.-x); the box grows by t, so the layer's base lies at
    x = 30 - t facing +x; Geant4's overlap check (in its own process, as the command runs)
    finds none, and Po-210 alphas from the layer deposit energy in the crystal."""
    import yaml

    from score4.runner.engine import run
    from score4.runner.output import read_results

    from helpers.boolean_worlds import write_world
    from helpers.g4_geometry_check import assert_no_overlaps

    gdml = write_world(tmp_path / "boolean.gdml")
    data = {
        **config(gdml, "second.-x", "ppc"),
        "source": {
            "particle": "alpha",
            "energy": "5.3 MeV",
            "surface": {"volume": "ppc", "face": "second.-x"},
        },
        "run": {"events": 30, "seed": 5},
    }
    del data["output"]
    cfg = parse_config(data)
    scene = build_scene(cfg)
    layer = scene.layer("ppc", "second.-x")
    base = scene.target("ppc").to_local(layer.frame.centre[None])[0]
    assert base[0] == pytest.approx(30.0 - layer.thickness, abs=1e-12)
    normal = scene.target("ppc").rotation.T @ layer.frame.normal
    assert normal == pytest.approx([1.0, 0.0, 0.0], abs=1e-12)
    assert 0.9 < layer.rough_share <= 1.0 + 1e-3  # the face's area is estimated
    (tmp_path / "ppc.yaml").write_text(yaml.safe_dump(data))
    assert_no_overlaps(tmp_path / "ppc.yaml")
    r = read_results(run(cfg, tmp_path / "a.h5", progress=False, echo=lambda m: None))
    edep = np.asarray(r.scores["edep"]["ppc"])
    assert (edep > 0).mean() > 0.3


def test_geantino_paths_through_a_deeper_blind_hole(gdml, tmp_path):
    """into: true on a blind hole's floor (face -z of a subtracted G4Tubs, z = 5 mm): the tube
    grows by t downward, the ring layer's base lies t below the old floor facing up; geantinos
    from inside the hole, down through its floor: Geant4's track length equals the analytic
    path in the box less the cylinder r < 3 mm, z > 5 - t, plus the path in the patch bodies
    near the ray, 1e-9 mm."""
    from score4.source.build import make_source

    from helpers.geantinos import geantino_run

    data = config(gdml, "second.-z", "blind")
    cfg = parse_config(data)
    scene = build_scene(cfg)
    layer = scene.layer("blind", "second.-z")
    target = scene.target("blind")
    t = layer.thickness
    assert target.to_local(layer.frame.centre[None])[0] == pytest.approx([0, 0, 5 - t], abs=1e-12)
    assert target.rotation.T @ layer.frame.normal == pytest.approx([0, 0, 1], abs=1e-12)
    rng = np.random.default_rng(5)
    n = 10
    local = np.column_stack([rng.uniform(-2, 2, (n, 2)), np.full(n, 9.0)])
    aims = np.column_stack([rng.uniform(-9, 9, (n, 2)), np.full(n, -9.0)])
    d = (aims - local) / np.linalg.norm(aims - local, axis=1, keepdims=True)
    starts, directions = target.to_world(local), d @ target.rotation.T
    primaries = make_source(cfg, scene).primaries(np.random.default_rng(1), 0, n)
    got = geantino_run(data, primaries, starts, directions, tmp_path)
    got = np.asarray(got.scores["track_length"]["blind"])
    crossed = 0
    for k in range(n):
        o, dk = local[k], d[k]
        s0, s1 = _slab(o, dk, np.full(3, -HALF), np.full(3, HALF))
        a, b = dk[0] ** 2 + dk[1] ** 2, 2 * (o[0] * dk[0] + o[1] * dk[1])
        root = np.sqrt(b * b - 4 * a * (o[0] ** 2 + o[1] ** 2 - 9.0))  # starts in the hole
        z0, z1 = sorted([(5.0 - t - o[2]) / dk[2], (15.0 - o[2]) / dk[2]])
        c0, c1 = max((-b - root) / (2 * a), z0), min((-b + root) / (2 * a), z1)
        in_patches = flat_patches_path(layer, starts[k], directions[k])
        crossed += in_patches > 0
        expected = (s1 - s0) - max(0.0, min(s1, c1) - max(s0, c0)) + in_patches
        assert got[k] == pytest.approx(expected, abs=1e-9, rel=0), k
    assert crossed >= n // 2
